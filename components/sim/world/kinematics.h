// Differential-drive kinematics and odometry noise: the pure maths of how a
// simulated robot moves under a velocity command and what its wheel
// encoders report (docs/components/sim-world.md, "Robot driver PEIS").
#pragma once

#include <random>

#include "sim/world/geometry.h"
#include "sim/world/world.h"

namespace peis::sim {

struct Velocity {
  double v = 0;  // m/s forward
  double w = 0;  // rad/s counter-clockwise
  bool operator==(const Velocity&) const = default;
};

struct DriveLimits {
  double maxSpeed = 0.5, maxTurn = 1.5, maxAccel = 1.0, maxTurnAccel = 3.0;
  static DriveLimits of(const Robot& robot) {
    return {robot.maxSpeed, robot.maxTurn, robot.maxAccel, robot.maxTurnAccel};
  }
};

// The command with each part clamped to the limits.
Velocity clampCommand(Velocity command, const DriveLimits& limits);
// One step of at most maxAccel·dt (maxTurnAccel·dt) from `current` towards `target`.
Velocity approach(Velocity current, Velocity target, const DriveLimits& limits, double dt);
// The pose after driving at `velocity` for `dt` (exact arc).
Pose2 integrate(Pose2 pose, Velocity velocity, double dt);

// One odometry increment: the distance and turn the encoders count.
struct OdometryStep {
  double distance = 0, turn = 0;
};
// Adds Gaussian noise: sd trans·|distance| on the distance, rot·|turn| +
// drift·|distance| on the turn.
OdometryStep noisy(OdometryStep truth, const OdometryNoise& noise, std::mt19937& rng);
// Accumulates an increment into an odometry pose (turning half before and
// half after the move, the usual midpoint rule).
Pose2 accumulate(Pose2 odometry, OdometryStep step);

}  // namespace peis::sim
