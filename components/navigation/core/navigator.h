// The navigation component's brain, without a network (ThinkingCap-like):
// goals in, velocity commands and ExecStatus out. It owns the costmap, the
// localizer, the planner and the path follower and decides when to plan,
// replan and give up:
//
//   idle ──goal──▶ pending (no map or pose yet) ──▶ following ──arrived──▶ success
//                      │                              │  ▲
//                      │                  bumper/sonar│  │replanned
//                      ▼                              ▼  │
//                  failed (cause)  ◀── no path ── backing off / replanning
//
// A goal arriving while another runs replaces it: the old one ends
// `failed <id> … replaced by goal <new id>` and the new one starts from where
// the robot is. `Stop` ends the running goal (`failed … stopped`) and halts.
//
// Time is sensor time in seconds (the Odometry tuples' ts_user).
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "astar.h"
#include "costmap.h"
#include "execution/exec_protocol.h"
#include "localizer.h"
#include "path_follower.h"

namespace peis::nav {

struct NavigatorOptions {
  InflationOptions inflation;
  LocalizerOptions localizer;
  FollowerOptions follower;
  PlanOptions planner;
  int maxReplans = 6;           // per goal, before `failed blocked`
  double backOffSeconds = 0.6;  // after a bump, reverse this long
  double backOffSpeed = 0.1;    // m/s
  // A pressed bumper is a (new) bump only once the robot has been told to
  // drive forward this long: a bumper that stays pressed after a back-off
  // (a base that reports it until the robot moves, a back-off that could not
  // move because the contact is beside or behind) must not end each replan
  // at once, before the new path, which may lead away, was even tried.
  double bumpGraceSeconds = 0.5;
  double obstacleRadius = 0.1;  // metres: what a sonar echo or a bump marks occupied
  double sonarLookAhead =
      0.35;  // metres beyond the rim: an unmapped echo this near, on the path, blocks it
  double mapWaitSeconds = 10.0;  // a goal waits this long for a map, then fails `no map`
  // Sonar geometry (from the driver's Geometry.* tuples).
  std::vector<double> sonarAngles;
  double sonarMaxRange = 3.0;
};

enum class NavState { Idle, Pending, Following, BackingOff };
const char* toString(NavState state);

// What the shell must do after an event.
struct NavOutput {
  std::optional<VelocityCommand> command;   // write VelCommand
  std::vector<exec::ExecStatus> statuses;   // write ExecStatus, in order
  std::optional<std::vector<Point2>> path;  // publish path.<robot> (empty: none)
  std::vector<std::string> log;             // lines for the log
};

// A named place's pose, or nothing (the shell looks up place.<name>).
using PlaceLookup = std::function<std::optional<Pose2>(const std::string& name)>;

class Navigator {
 public:
  Navigator(NavigatorOptions options, PlaceLookup places);

  void setMap(const OccupancyGrid& grid);
  // The robot's geometry as the driver states it (Geometry.* tuples):
  // radius, sonar angles and range, speed limits. Rebuilds the costmap.
  void setGeometry(double radius, std::vector<double> sonarAngles, double sonarMaxRange,
                   double maxSpeed, double maxTurnRate);
  bool hasMap() const { return costmap_.grid().width() > 0; }
  // A goal written to ExecGoal, with the id the status will carry.
  NavOutput onGoal(const exec::Action& action, std::uint64_t goalId);
  // A malformed ExecGoal: reported failed at once (the running goal goes on).
  NavOutput onMalformedGoal(const std::string& text, std::uint64_t goalId,
                            const std::string& problem);
  // Odometry drives the control loop: one command per reading.
  NavOutput onOdometry(const Pose2& odometry, double time);
  void onFix(Point2 position, double time) { localizer_.onFix(position, time); }
  void onBumper(bool pressed) { bumper_ = pressed; }
  void onSonar(const std::vector<double>& ranges) { sonar_ = ranges; }
  // Push through obstacles met on the way (a light parcel) instead of
  // marking them and going around: bumper and sonar are then ignored.
  void setPushObstacles(bool push) { push_ = push; }
  bool pushObstacles() const { return push_; }

  NavState state() const { return state_; }
  const Localizer& localizer() const { return localizer_; }
  const Costmap& costmap() const { return costmap_; }
  const std::vector<Point2>& path() const { return follower_.waypoints(); }
  int replans() const { return replans_; }

 private:
  struct Target {
    Point2 position;
    std::optional<double> heading;
  };
  struct Goal {
    std::uint64_t id = 0;
    std::string action;
    Target target;
    double waitingSince = -1;
    // A place goal that came before the map (and its places): resolved once it is there.
    std::optional<exec::Action> unresolved;
  };

  // Resolves GoTo's arguments to a target; a cause when it cannot.
  std::optional<Target> resolve(const exec::Action& action, std::string& cause) const;
  void finish(NavOutput& out, exec::ExecState state, const std::string& cause = {});
  bool plan(NavOutput& out, const Pose2& pose);
  bool sonarBlocksPath(const Pose2& pose, NavOutput& out);

  NavigatorOptions options_;
  PlaceLookup places_;
  Costmap costmap_;
  OccupancyGrid mapGrid_;  // as received, before sensed obstacles
  Localizer localizer_;
  PathFollower follower_;
  NavState state_ = NavState::Idle;
  std::optional<Goal> goal_;
  int replans_ = 0;
  bool marksForgotten_ = false;  // this goal's sensed obstacles were forgotten once
  bool bumper_ = false;
  bool push_ = false;
  std::vector<double> sonar_;
  double backOffUntil_ = 0;
  double forwardSince_ = -1;  // sensor time since the commands drive forward (-1: they do not)
  double lastTime_ = 0;
};

}  // namespace peis::nav
