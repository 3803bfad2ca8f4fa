// Where the robot is: odometry corrected by absolute fixes. A ceiling-camera
// tracker gives the position (a coloured hat has no heading) at the time of
// its images; the wheels give a smooth but drifting pose. The localizer keeps
// the rigid transform from the odometry frame to the map frame:
//
//   map pose = correction ⊕ odometry pose
//
// Each fix pulls the position of that transform towards the fix (at the
// odometry pose of the fix's time), and once the robot has moved far enough
// between two fixes, the heading too (the direction of travel seen by the
// fixes against the one the odometry saw). While fixes are fresh the estimate
// is `Fix`-based; when they stop (robot out of the cameras' view, tracker
// gone, input not configured) the correction is simply kept: dead reckoning
// from the last good fix. The switch either way needs no stop, since the
// estimate is continuous apart from the corrections themselves.
//
// Time is the sensors' time (ts_user: simulated time in the simulation), in
// seconds. Pure: no I/O, no clock.
#pragma once

#include <deque>
#include <optional>

#include "pose.h"

namespace peis::nav {

enum class PoseSource { None, Fix, Odometry };
const char* toString(PoseSource source);

struct LocalizerOptions {
  double fixFreshness = 1.0;     // seconds: a fix older than this (vs. odometry time) is stale
  double positionGain = 0.5;     // share of a fix's position residual applied
  double headingGain = 0.5;      // share of the heading residual applied
  double headingBaseline = 0.5;  // metres travelled between fixes before heading is corrected
  double historySeconds = 3.0;   // odometry kept to look up the pose at a fix's time
};

struct PoseEstimate {
  Pose2 pose;
  PoseSource source = PoseSource::None;
  double time = 0;  // of the odometry reading it is based on
};

class Localizer {
 public:
  explicit Localizer(LocalizerOptions options = {});

  // An odometry reading (pose in the odometry frame) at sensor time `time`.
  void onOdometry(const Pose2& odometry, double time);
  // A position fix in the map frame at sensor time `time`. Fixes older than
  // the odometry history, or from the future, are ignored (returns false).
  bool onFix(Point2 position, double time);
  // Re-anchors the map frame: the robot is at `pose` now (e.g. a known start).
  void reset(const Pose2& pose);

  std::optional<PoseEstimate> estimate() const;
  bool fixFresh() const;
  const Pose2& correction() const { return correction_; }
  int fixesUsed() const { return fixesUsed_; }

 private:
  std::optional<Pose2> odometryAt(double time) const;

  LocalizerOptions options_;
  Pose2 correction_;                              // map <- odometry
  std::deque<std::pair<double, Pose2>> history_;  // (time, odometry pose), oldest first
  std::optional<double> lastFixTime_;
  // The fix that starts the current heading baseline, with the odometry pose then.
  std::optional<std::pair<Point2, Pose2>> anchor_;
  int fixesUsed_ = 0;
};

}  // namespace peis::nav
