// Simulation: the state of a home that changes while it runs (robots'
// true poses, velocities, odometry, bumpers and batteries; objects pushed
// around; people asleep or awake; the light) and the step that advances it
// by dt seconds of simulated time. Pure: no clock, no network, one seeded
// random generator, so a run is reproducible and testable.
#pragma once

#include <optional>
#include <random>
#include <string>
#include <vector>

#include "sim/world/kinematics.h"
#include "sim/world/light_model.h"
#include "sim/world/world.h"

namespace peis::sim {

struct RobotState {
  Pose2 pose;               // ground truth
  Velocity velocity;        // ground truth
  Velocity command;         // the last VelCommand (clamped)
  double commandAge = 1e9;  // seconds since it came
  Pose2 odometry;           // what the encoders integrate (noisy)
  Velocity measured;        // the encoders' velocities (noisy)
  bool bumper = false;
  double battery = 100;     // percent
  double distance = 0;      // metres travelled
  std::vector<Vec2> trail;  // ground-truth path, a point every 2 cm
};

struct Speech {
  std::string robot;
  Pose2 at;
  std::string text;
  double time = 0;
  std::vector<std::string> woke;  // people this talk woke up
};

class Simulation {
 public:
  Simulation(World world, std::uint32_t seed);
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  const World& world() const { return world_; }
  double time() const { return time_; }
  std::optional<std::size_t> robotIndex(std::string_view name) const;
  std::optional<std::size_t> objectIndex(std::string_view name) const;

  const RobotState& robot(std::size_t index) const { return robots_.at(index); }
  const Pose2& objectPose(std::size_t index) const { return objects_.at(index); }
  const std::string& personState(std::size_t index) const { return people_.at(index); }
  const LightState& light() const { return light_; }
  LightState& light() { return light_; }

  // A VelCommand for a robot: held for its cmd_timeout of simulated time.
  void command(std::size_t robot, Velocity velocity);
  // A TalkCommand: who heard it and woke up.
  Speech talk(std::size_t robot, std::string text);
  // Advances by dt seconds (at most 0.1; longer steps are split).
  void step(double dt);
  // One noisy range per sonar, metres from the robot's rim.
  std::vector<double> sonar(std::size_t robot);
  // Range without noise along a ray from `origin` (ignoring robot `self`).
  double castRay(Vec2 origin, double angle, double maxRange, std::optional<std::size_t> self) const;

  // True if a disk of `radius` at `centre` touches no wall, furniture,
  // fixed object, robot (but `robot`) or movable object (but `object`).
  bool diskFree(Vec2 centre, double radius, std::optional<std::size_t> robot,
                std::optional<std::size_t> object) const;

 private:
  void stepRobot(std::size_t index, double dt);
  bool staticFree(Vec2 centre, double radius) const;
  bool tryPush(std::size_t robot, Vec2 robotAt);

  World world_;
  std::mt19937 rng_;
  double time_ = 0;
  std::vector<Polygon> obstacles_;
  std::vector<std::pair<Vec2, Vec2>> obstacleBoxes_;  // bounding boxes of obstacles_
  std::vector<RobotState> robots_;
  std::vector<Pose2> objects_;
  std::vector<std::string> people_;
  LightState light_;
};

}  // namespace peis::sim
