// Differential-drive kinematics and odometry noise (kinematics.h).
#include "sim/world/kinematics.h"

#include <algorithm>
#include <cmath>

namespace peis::sim {

Velocity clampCommand(Velocity command, const DriveLimits& limits) {
  return {std::clamp(command.v, -limits.maxSpeed, limits.maxSpeed),
          std::clamp(command.w, -limits.maxTurn, limits.maxTurn)};
}

Velocity approach(Velocity current, Velocity target, const DriveLimits& limits, double dt) {
  const auto towards = [dt](double from, double to, double rate) {
    const double most = rate * dt;
    return from + std::clamp(to - from, -most, most);
  };
  target = clampCommand(target, limits);
  return {towards(current.v, target.v, limits.maxAccel),
          towards(current.w, target.w, limits.maxTurnAccel)};
}

Pose2 integrate(Pose2 pose, Velocity velocity, double dt) {
  const double turn = velocity.w * dt;
  Pose2 next = pose;
  if (std::abs(turn) < 1e-9) {
    next.x += velocity.v * dt * std::cos(pose.theta);
    next.y += velocity.v * dt * std::sin(pose.theta);
  } else {
    const double radius = velocity.v / velocity.w;
    next.x += radius * (std::sin(pose.theta + turn) - std::sin(pose.theta));
    next.y -= radius * (std::cos(pose.theta + turn) - std::cos(pose.theta));
  }
  next.theta = normalizeAngle(pose.theta + turn);
  return next;
}

OdometryStep noisy(OdometryStep truth, const OdometryNoise& noise, std::mt19937& rng) {
  std::normal_distribution<double> unit(0.0, 1.0);
  const double sdDistance = noise.trans * std::abs(truth.distance);
  const double sdTurn = noise.rot * std::abs(truth.turn) + noise.drift * std::abs(truth.distance);
  return {truth.distance + sdDistance * unit(rng), truth.turn + sdTurn * unit(rng)};
}

Pose2 accumulate(Pose2 odometry, OdometryStep step) {
  const double heading = odometry.theta + step.turn / 2;
  return {odometry.x + step.distance * std::cos(heading),
          odometry.y + step.distance * std::sin(heading),
          normalizeAngle(odometry.theta + step.turn)};
}

}  // namespace peis::sim
