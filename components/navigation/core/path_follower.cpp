// Pure pursuit along a waypoint path (see path_follower.h).
#include "path_follower.h"

#include <algorithm>
#include <cmath>

namespace peis::nav {

namespace {

// The parameter of the projection of p on segment ab, clamped to [0, 1].
double project(Point2 p, Point2 a, Point2 b) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double len2 = dx * dx + dy * dy;
  if (len2 <= 0) return 1.0;
  return std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / len2, 0.0, 1.0);
}

Point2 lerp(Point2 a, Point2 b, double t) { return {a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t}; }

}  // namespace

PathFollower::PathFollower(FollowerOptions options) : options_(options) {}

void PathFollower::setPath(std::vector<Point2> waypoints, std::optional<double> goalHeading) {
  waypoints_ = std::move(waypoints);
  goalHeading_ = goalHeading;
  segment_ = 0;
  atPosition_ = false;
  arrived_ = waypoints_.empty();
  remaining_ = 0;
}

void PathFollower::clear() { setPath({}, std::nullopt); }

VelocityCommand PathFollower::update(const Pose2& pose) {
  if (waypoints_.empty() || arrived_) return {};
  const Point2 here = pose.position();
  const Point2 goal = waypoints_.back();
  const double toGoal = distance(here, goal);

  if (!atPosition_ && toGoal <= options_.goalTolerance) atPosition_ = true;
  if (atPosition_) {
    remaining_ = 0;
    if (!goalHeading_) {
      arrived_ = true;
      return {};
    }
    const double error = normalizeAngle(*goalHeading_ - pose.theta);
    if (std::abs(error) <= options_.headingTolerance) {
      arrived_ = true;
      return {};
    }
    const double w =
        std::clamp(options_.turnGain * error, -options_.maxTurnRate, options_.maxTurnRate);
    // Keep turning fast enough to overcome a sluggish base near the end.
    return {0, std::copysign(std::max(std::abs(w), 0.15), error)};
  }

  // Advance along the path: the segment whose projection is nearest, looking
  // only forward (a path never makes the robot go back over itself).
  if (waypoints_.size() == 1) waypoints_.insert(waypoints_.begin(), here);
  while (segment_ + 2 < waypoints_.size()) {
    const Point2 a = waypoints_[segment_], b = waypoints_[segment_ + 1];
    const double t = project(here, a, b);
    const Point2 onThis = lerp(a, b, t);
    const Point2 c = waypoints_[segment_ + 2];
    const Point2 onNext = lerp(b, c, project(here, b, c));
    if (t >= 1.0 - 1e-9 || distance(here, onNext) < distance(here, onThis)) {
      ++segment_;
    } else {
      break;
    }
  }
  // The carrot: `lookahead` along the path from the projection.
  const Point2 a = waypoints_[segment_], b = waypoints_[segment_ + 1];
  Point2 from = lerp(a, b, project(here, a, b));
  double budget = options_.lookahead;
  std::size_t i = segment_ + 1;
  remaining_ = 0;
  carrot_ = goal;
  bool placed = false;
  for (;; ++i) {
    const double len = distance(from, waypoints_[i]);
    if (!placed && len >= budget) {
      carrot_ = lerp(from, waypoints_[i], len > 0 ? budget / len : 1.0);
      placed = true;
    }
    if (!placed) budget -= len;
    remaining_ += len;
    from = waypoints_[i];
    if (i + 1 >= waypoints_.size()) break;
  }
  // Near the goal, steer at the goal itself.
  if (toGoal < options_.lookahead) carrot_ = goal;

  const double bearing = std::atan2(carrot_.y - here.y, carrot_.x - here.x);
  const double alpha = normalizeAngle(bearing - pose.theta);
  if (std::abs(alpha) > options_.turnInPlaceAbove) {
    const double w =
        std::clamp(options_.turnGain * alpha, -options_.maxTurnRate, options_.maxTurnRate);
    return {0, w};
  }
  const double approach = std::min(remaining_, toGoal * 1.5);
  double v = options_.maxSpeed;
  if (approach < options_.approachDistance)
    v = std::max(options_.minApproachSpeed,
                 options_.maxSpeed * approach / options_.approachDistance);
  v *= std::max(0.2, std::cos(alpha));
  const double lookahead = std::max(distance(here, carrot_), 1e-3);
  double w = 2.0 * v * std::sin(alpha) / lookahead;  // pure pursuit curvature times speed
  w += 0.5 * options_.turnGain * alpha * (v < 0.1 ? 1.0 : 0.0);  // help at crawl speed
  w = std::clamp(w, -options_.maxTurnRate, options_.maxTurnRate);
  return {v, w};
}

}  // namespace peis::nav
