// Following a path of waypoints with a differential-drive robot: pure
// pursuit towards a carrot point a look-ahead distance along the path,
// turning in place first when the carrot is far off to the side, slowing
// down on the approach, and a final turn to the goal's heading when it has
// one. Pure: pose in, (v, w) out.
#pragma once

#include <optional>
#include <vector>

#include "pose.h"

namespace peis::nav {

struct FollowerOptions {
  double maxSpeed = 0.35;          // m/s
  double maxTurnRate = 1.0;        // rad/s
  double lookahead = 0.35;         // metres
  double goalTolerance = 0.03;     // metres: arrived
  double headingTolerance = 0.08;  // radians: final heading reached
  double turnInPlaceAbove = 0.7;   // radians of heading error
  double approachDistance = 0.5;   // metres: start slowing down
  double minApproachSpeed = 0.04;  // m/s: slowest forward speed
  double turnGain = 2.0;           // rad/s per radian
};

struct VelocityCommand {
  double v = 0, w = 0;
  bool operator==(const VelocityCommand&) const = default;
};

class PathFollower {
 public:
  explicit PathFollower(FollowerOptions options = {});

  // A new path (start to goal); `goalHeading` asks for a final turn.
  void setPath(std::vector<Point2> waypoints, std::optional<double> goalHeading);
  void clear();
  bool hasPath() const { return !waypoints_.empty(); }
  const std::vector<Point2>& waypoints() const { return waypoints_; }
  // The index of the waypoint the robot is heading for.
  std::size_t nextWaypoint() const { return segment_ + 1; }

  // The command for the robot at `pose`; `arrived()` tells when done.
  VelocityCommand update(const Pose2& pose);
  bool arrived() const { return arrived_; }
  // Distance still to go along the path from the last pose given.
  double remaining() const { return remaining_; }
  // The point the robot steers towards (for pictures and tests).
  Point2 carrot() const { return carrot_; }

 private:
  FollowerOptions options_;
  std::vector<Point2> waypoints_;
  std::optional<double> goalHeading_;
  std::size_t segment_ = 0;  // the segment (waypoints_[segment_], [segment_+1]) being followed
  bool atPosition_ = false;
  bool arrived_ = false;
  double remaining_ = 0;
  Point2 carrot_;
};

}  // namespace peis::nav
