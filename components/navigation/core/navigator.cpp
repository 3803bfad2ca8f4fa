// The navigation state machine (see navigator.h).
#include "navigator.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace peis::nav {

const char* toString(NavState state) {
  switch (state) {
    case NavState::Idle:
      return "idle";
    case NavState::Pending:
      return "pending";
    case NavState::Following:
      return "following";
    case NavState::BackingOff:
      return "backing-off";
  }
  return "idle";
}

namespace {

std::string describe(Point2 p) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "(%.2f, %.2f)", p.x, p.y);
  return buf;
}

}  // namespace

Navigator::Navigator(NavigatorOptions options, PlaceLookup places)
    : options_(std::move(options)),
      places_(std::move(places)),
      localizer_(options_.localizer),
      follower_(options_.follower) {}

void Navigator::setMap(const OccupancyGrid& grid) {
  mapGrid_ = grid;
  costmap_ = Costmap(grid, options_.inflation);
}

void Navigator::setGeometry(double radius, std::vector<double> sonarAngles, double sonarMaxRange,
                            double maxSpeed, double maxTurnRate) {
  options_.inflation.robotRadius = radius;
  options_.sonarAngles = std::move(sonarAngles);
  options_.sonarMaxRange = sonarMaxRange;
  if (maxSpeed > 0) options_.follower.maxSpeed = std::min(options_.follower.maxSpeed, maxSpeed);
  if (maxTurnRate > 0)
    options_.follower.maxTurnRate = std::min(options_.follower.maxTurnRate, maxTurnRate);
  if (!follower_.hasPath()) follower_ = PathFollower(options_.follower);
  if (hasMap()) costmap_ = Costmap(mapGrid_, options_.inflation);
}

std::optional<Navigator::Target> Navigator::resolve(const exec::Action& action,
                                                    std::string& cause) const {
  if (action.args.size() == 1) {
    if (const auto place = places_ ? places_(action.args[0]) : std::nullopt)
      return Target{place->position(), place->theta};
    cause = "unknown place '" + action.args[0] + "'";
    return std::nullopt;
  }
  if (action.args.size() == 2 || action.args.size() == 3) {
    Target target;
    const auto x = exec::parseNumber(action.args[0]);
    const auto y = exec::parseNumber(action.args[1]);
    if (!x || !y) {
      cause = "GoTo(X, Y[, THETA]) takes numbers";
      return std::nullopt;
    }
    target.position = {*x, *y};
    if (action.args.size() == 3) {
      target.heading = exec::parseNumber(action.args[2]);
      if (!target.heading) {
        cause = "GoTo(X, Y, THETA) takes numbers";
        return std::nullopt;
      }
    }
    return target;
  }
  cause = "GoTo takes a place or X, Y[, THETA]";
  return std::nullopt;
}

void Navigator::finish(NavOutput& out, exec::ExecState state, const std::string& cause) {
  if (!goal_) return;
  out.statuses.push_back({state, goal_->id, goal_->action, cause});
  out.log.push_back(std::string(exec::toString(state)) + " " + goal_->action +
                    (cause.empty() ? "" : ": " + cause));
  out.command = VelocityCommand{0, 0};
  out.path = std::vector<Point2>{};
  goal_.reset();
  follower_.clear();
  forwardSince_ = -1;
  state_ = NavState::Idle;
}

NavOutput Navigator::onMalformedGoal(const std::string& text, std::uint64_t goalId,
                                     const std::string& problem) {
  NavOutput out;
  out.statuses.push_back(
      {exec::ExecState::Failed, goalId, "Malformed", "malformed goal '" + text + "': " + problem});
  return out;
}

NavOutput Navigator::onGoal(const exec::Action& action, std::uint64_t goalId) {
  NavOutput out;
  const std::string text = action.toString();
  if (action.name == "Stop" && action.args.empty()) {
    finish(out, exec::ExecState::Failed, "stopped by goal " + std::to_string(goalId));
    out.command = VelocityCommand{0, 0};
    out.statuses.push_back({exec::ExecState::Success, goalId, text, ""});
    return out;
  }
  if (action.name != "GoTo") {
    out.statuses.push_back(
        {exec::ExecState::Failed, goalId, text,
         "unsupported action '" + action.name + "' (navigation does GoTo, Stop)"});
    return out;
  }
  std::string cause;
  const auto target = resolve(action, cause);
  // Before the map has come, places may not have come either: wait for them.
  const bool waitForPlaces = !target && !hasMap() && action.args.size() == 1;
  if (!target && !waitForPlaces) {
    out.statuses.push_back({exec::ExecState::Failed, goalId, text, cause});
    return out;
  }
  // A goal while another runs replaces it.
  finish(out, exec::ExecState::Failed, "replaced by goal " + std::to_string(goalId));
  out.command.reset();
  goal_ = Goal{goalId, text, target.value_or(Target{}), -1,
               waitForPlaces ? std::optional<exec::Action>(action) : std::nullopt};
  replans_ = 0;
  marksForgotten_ = false;
  if (costmap_.grid().cells() != mapGrid_.cells()) costmap_ = Costmap(mapGrid_, options_.inflation);
  state_ = NavState::Pending;
  out.statuses.push_back({exec::ExecState::Running, goalId, text, ""});
  out.log.push_back(
      "goal " + std::to_string(goalId) + ": " + text +
      (target ? " -> " + describe(target->position) : " (waiting for the map's places)"));
  if (const auto estimate = localizer_.estimate(); estimate && hasMap()) plan(out, estimate->pose);
  return out;
}

bool Navigator::plan(NavOutput& out, const Pose2& pose) {
  PlannedPath planned =
      planPath(costmap_, pose.position(), goal_->target.position, options_.planner);
  if (!planned.found() && !marksForgotten_ && costmap_.grid().cells() != mapGrid_.cells()) {
    // What the sonars and the bumper marked may be what boxes the robot in
    // (someone who has walked on, echoes marked while the estimate jumped):
    // forgotten once per goal, planned on the map alone. What is really
    // there is seen and marked again, and a second trap fails the goal.
    marksForgotten_ = true;
    costmap_ = Costmap(mapGrid_, options_.inflation);
    out.log.push_back(std::string(toString(planned.failure)) +
                      " with the obstacles marked: forgetting them, planning on the map");
    planned = planPath(costmap_, pose.position(), goal_->target.position, options_.planner);
  }
  if (!planned.found()) {
    finish(out, exec::ExecState::Failed, toString(planned.failure));
    return false;
  }
  follower_.setPath(planned.waypoints, goal_->target.heading);
  out.path = planned.waypoints;
  std::ostringstream line;
  line << "planned " << planned.waypoints.size() << " waypoints, " << planned.length << " m, "
       << planned.expanded << " cells expanded";
  out.log.push_back(line.str());
  state_ = NavState::Following;
  return true;
}

bool Navigator::sonarBlocksPath(const Pose2& pose, NavOutput& out) {
  const double radius = options_.inflation.robotRadius;
  bool added = false;
  for (std::size_t i = 0; i < sonar_.size() && i < options_.sonarAngles.size(); ++i) {
    const double range = sonar_[i];
    if (!(range >= 0) || range >= options_.sonarMaxRange || range > options_.sonarLookAhead)
      continue;
    const double angle = pose.theta + options_.sonarAngles[i];
    const double reach = radius + range + 0.5 * options_.obstacleRadius;
    const Point2 hit{pose.x + reach * std::cos(angle), pose.y + reach * std::sin(angle)};
    const Cell cell = mapGrid_.cellOf(hit);
    bool known = false;  // an echo off the map's walls or furniture, or one marked already
    for (int dy = -2; dy <= 2 && !known; ++dy)
      for (int dx = -2; dx <= 2 && !known; ++dx) {
        const Cell c{cell.x + dx, cell.y + dy};
        known = !mapGrid_.inside(c) || mapGrid_.occupied(c) || costmap_.grid().occupied(c);
      }
    if (known) continue;
    costmap_.addObstacle(hit, options_.obstacleRadius);
    out.log.push_back("sonar " + std::to_string(i) + ": obstacle at " + describe(hit));
    added = true;
  }
  if (!added) return false;
  // Replan only if what is left of the path now crosses a lethal cell. The
  // robot's own cell may be lethal right after marking an echo beside it:
  // then the segment it is on is not checked (the replan would start there).
  const auto& waypoints = follower_.waypoints();
  const bool robotInLethal = costmap_.lethal(costmap_.grid().cellOf(pose.position()));
  Point2 from = pose.position();
  const std::size_t next = follower_.nextWaypoint();
  for (std::size_t i = next; i < waypoints.size(); ++i) {
    if (!(i == next && robotInLethal) && !segmentFree(costmap_, from, waypoints[i])) return true;
    from = waypoints[i];
  }
  return false;
}

NavOutput Navigator::onOdometry(const Pose2& odometry, double time) {
  NavOutput out;
  localizer_.onOdometry(odometry, time);
  lastTime_ = time;
  const auto estimate = localizer_.estimate();
  if (!goal_ || !estimate) return out;
  const Pose2 pose = estimate->pose;
  switch (state_) {
    case NavState::Idle:
      break;
    case NavState::Pending:
      if (!hasMap()) {
        if (goal_->waitingSince < 0) goal_->waitingSince = time;
        if (time - goal_->waitingSince > options_.mapWaitSeconds)
          finish(out, exec::ExecState::Failed, "no map");
        break;
      }
      if (goal_->unresolved) {
        std::string cause;
        const auto target = resolve(*goal_->unresolved, cause);
        if (!target) {
          finish(out, exec::ExecState::Failed, cause);
          break;
        }
        goal_->target = *target;
        goal_->unresolved.reset();
      }
      if (plan(out, pose)) out.command = follower_.update(pose);
      break;
    case NavState::BackingOff:
      if (time < backOffUntil_) {
        out.command = VelocityCommand{-options_.backOffSpeed, 0};
      } else if (plan(out, pose)) {
        out.command = follower_.update(pose);
      }
      break;
    case NavState::Following: {
      if (bumper_ && !push_ && forwardSince_ >= 0 &&
          time - forwardSince_ >= options_.bumpGraceSeconds) {
        if (++replans_ > options_.maxReplans) {
          finish(out, exec::ExecState::Failed, "blocked");
          break;
        }
        const double ahead = options_.inflation.robotRadius + 0.5 * options_.obstacleRadius;
        const Point2 contact{pose.x + ahead * std::cos(pose.theta),
                             pose.y + ahead * std::sin(pose.theta)};
        if (mapGrid_.contains(contact) && !mapGrid_.occupied(mapGrid_.cellOf(contact)))
          costmap_.addObstacle(contact, options_.obstacleRadius);
        out.log.push_back("bumped at " + describe(pose.position()) + ": backing off, replanning");
        state_ = NavState::BackingOff;
        backOffUntil_ = time + options_.backOffSeconds;
        out.command = VelocityCommand{-options_.backOffSpeed, 0};
        break;
      }
      if (!push_ && sonarBlocksPath(pose, out)) {
        if (++replans_ > options_.maxReplans) {
          finish(out, exec::ExecState::Failed, "blocked");
          break;
        }
        out.log.push_back("path blocked: replanning");
        if (!plan(out, pose)) break;
      }
      out.command = follower_.update(pose);
      if (follower_.arrived()) finish(out, exec::ExecState::Success);
      break;
    }
  }
  if (out.command) {
    if (out.command->v <= 0)
      forwardSince_ = -1;
    else if (forwardSince_ < 0)
      forwardSince_ = time;
  }
  return out;
}

}  // namespace peis::nav
