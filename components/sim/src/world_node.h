// WorldNode: the PEIS shell of the simulated home (peis-sim-world). It runs
// the Simulation on a simulated clock (`speed` times real time), hosts one
// driver PEIS per robot, serves the map and places, publishes the physics
// channel for simulated sensors, takes physics inputs from simulated
// actuators, collects the estimates and paths other PEIS publish, and draws
// the top-down picture on request and at the end. The contract is
// docs/components/sim-world.md; the Simulation itself is pure (world/).
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "driver_node.h"
#include "peis/component.h"
#include "peis/kernel.h"
#include "sim/world/light_model.h"
#include "sim/world/simulation.h"
#include "sim/world/top_down.h"

namespace peis::sim {

struct WorldConfig {
  double speed = 1;                // simulated seconds per real second
  double tick = 0.01;              // physics step, simulated seconds
  std::optional<double> duration;  // end after this much simulated time
  double sceneHz = 20;             // physics.scene rate, simulated
  std::uint32_t seed = 1;
  std::string picturePath = "sim-world.png";                  // empty: no picture at the end
  double pictureScale = 100;                                  // pixels per metre
  std::vector<std::pair<std::string, std::string>> bindings;  // physics key, OWNER.KEY
  Options peis;  // the world PEIS's options (drivers copy them)
};

class WorldNode {
 public:
  // Throws Error(InvalidArgument) for a binding to an unknown physics input.
  WorldNode(WorldConfig config, World world);
  ~WorldNode();
  WorldNode(const WorldNode&) = delete;
  WorldNode& operator=(const WorldNode&) = delete;

  Kernel& kernel() { return *kernel_; }
  // Runs until the duration, kernel.do-quit, SIGINT or SIGTERM; then writes
  // the picture. Returns why it ended.
  std::string run();
  // The picture now, as PNG bytes.
  std::string picture();

 private:
  struct Schedule {
    double period, next = 0;
    bool due(double now) {
      if (now + 1e-9 < next) return false;
      next = std::max(next + period, now);
      return true;
    }
  };
  struct Reading;  // what one tick publishes, gathered under the lock

  void publishStatic();
  void installGate();
  void tick();
  void publish(const Reading& reading);
  void onPhysicsInput(const Tuple& t);
  void onEstimate(const Tuple& t, bool isPath);
  void onTalk(std::size_t robot, std::string text);
  void bindPending();
  Timestamp stamp(double simTime) const;
  std::vector<std::string> physicsInputs() const;
  void say(double simTime, const std::string& what);

  WorldConfig config_;
  std::unique_ptr<Kernel> kernel_;
  std::unique_ptr<Component> component_;
  mutable std::mutex mu_;  // guards everything below it
  Simulation sim_;
  LightModel light_;
  std::map<std::pair<std::string, PeisId>, Estimate> estimates_;
  std::map<std::pair<std::string, PeisId>, PlannedPath> paths_;
  bool lightChanged_ = true;
  std::map<std::string, double> publishedLight_;
  std::map<std::string, Pose2> publishedObjects_;
  std::map<std::string, std::string> publishedPeople_;
  Schedule odometry_{0.05}, sonar_{0.1}, battery_{1.0}, scene_{0.05}, clock_{0.1}, lightTimer_{1.0};
  std::chrono::steady_clock::time_point anchorWall_;
  double anchorSim_ = 0;
  bool warnedLag_ = false;

  Timestamp startStamp_;
  std::vector<std::unique_ptr<DriverNode>> drivers_;
  std::vector<CallbackHandle> callbacks_;
  std::optional<TimerHandle> tickTimer_, bindTimer_;
  struct Binding {
    std::string physicsKey;
    FullName source;
    bool bound = false;
  };
  std::vector<Binding> bindings_;
};

}  // namespace peis::sim
