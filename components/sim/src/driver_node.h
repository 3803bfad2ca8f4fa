// DriverNode: one simulated robot's driver PEIS (Player-like), hosted in
// peis-sim-world with a Kernel of its own. It owns the keys a hardware
// driver would: VelCommand and TalkCommand in, Odometry, SonarRange, Bumper,
// Battery and Geometry.* out (docs/components/sim-world.md). Malformed
// commands are refused through the write gate; good ones go to `onCommand`
// and `onTalk` (on the driver's kernel thread).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "peis/component.h"
#include "peis/kernel.h"
#include "sim/world/kinematics.h"
#include "sim/world/world.h"

namespace peis::sim {

// "V W" -> a velocity; nullopt unless exactly two finite numbers.
std::optional<Velocity> parseVelCommand(std::string_view text);
inline constexpr std::size_t kMaxTalkBytes = 200;

class DriverNode {
 public:
  DriverNode(Options options, const Robot& robot, std::function<void(Velocity)> onCommand,
             std::function<void(std::string)> onTalk);
  ~DriverNode();

  Kernel& kernel() { return *kernel_; }
  const std::string& robot() const { return robot_; }

  // Sensor readings, stamped with the simulated time.
  void publishOdometry(Pose2 odometry, Velocity measured, Timestamp at);
  void publishSonar(const std::vector<double>& ranges, Timestamp at);
  void publishBumper(bool pressed, Timestamp at);
  void publishBattery(double percent, Timestamp at);

 private:
  std::string robot_;
  std::unique_ptr<Kernel> kernel_;
  std::unique_ptr<Component> component_;
  std::vector<CallbackHandle> callbacks_;
  std::optional<bool> bumper_;
};

}  // namespace peis::sim
