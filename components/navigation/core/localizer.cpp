// Odometry corrected by absolute position fixes (see localizer.h).
#include "localizer.h"

#include <cmath>

namespace peis::nav {

const char* toString(PoseSource source) {
  switch (source) {
    case PoseSource::None:
      return "none";
    case PoseSource::Fix:
      return "fix";
    case PoseSource::Odometry:
      return "odometry";
  }
  return "none";
}

Localizer::Localizer(LocalizerOptions options) : options_(options) {}

void Localizer::onOdometry(const Pose2& odometry, double time) {
  if (!history_.empty() && time < history_.back().first) history_.clear();  // clock restarted
  history_.emplace_back(time, odometry);
  while (history_.size() > 2 && history_.front().first < time - options_.historySeconds)
    history_.pop_front();
}

std::optional<Pose2> Localizer::odometryAt(double time) const {
  if (history_.empty()) return std::nullopt;
  if (time > history_.back().first + 0.5) return std::nullopt;  // from the future
  if (time >= history_.back().first) return history_.back().second;
  if (time < history_.front().first) return std::nullopt;
  for (std::size_t i = 1; i < history_.size(); ++i) {
    if (history_[i].first < time) continue;
    const auto& [t0, a] = history_[i - 1];
    const auto& [t1, b] = history_[i];
    const double s = t1 > t0 ? (time - t0) / (t1 - t0) : 1.0;
    return Pose2{a.x + (b.x - a.x) * s, a.y + (b.y - a.y) * s,
                 normalizeAngle(a.theta + normalizeAngle(b.theta - a.theta) * s)};
  }
  return history_.back().second;
}

bool Localizer::onFix(Point2 position, double time) {
  const auto odometry = odometryAt(time);
  if (!odometry || !std::isfinite(position.x) || !std::isfinite(position.y)) return false;
  // Heading: the direction of travel between the anchor fix and this one, as
  // the fixes saw it and as the (corrected) odometry saw it.
  if (anchor_) {
    const auto& [anchorFix, anchorOdometry] = *anchor_;
    const double travelled = distance(anchorFix, position);
    if (travelled >= options_.headingBaseline) {
      const Pose2 mapThen = compose(correction_, anchorOdometry);
      const Pose2 mapNow = compose(correction_, *odometry);
      const double seen = std::atan2(position.y - anchorFix.y, position.x - anchorFix.x);
      const double believed = std::atan2(mapNow.y - mapThen.y, mapNow.x - mapThen.x);
      const double odometryTravel = distance(mapThen.position(), mapNow.position());
      if (odometryTravel >= 0.5 * options_.headingBaseline) {
        const double turn = options_.headingGain * normalizeAngle(seen - believed);
        // Rotate the odometry frame about the robot's current position.
        const Pose2 pivot = compose(correction_, *odometry);
        const Pose2 rotated{0, 0, turn};
        const Pose2 aboutPivot{pivot.x, pivot.y, 0};
        correction_ =
            compose(compose(compose(aboutPivot, rotated), inverse(aboutPivot)), correction_);
      }
      anchor_ = {{position, *odometry}};
    }
  } else {
    anchor_ = {{position, *odometry}};
  }
  // Position: move the map frame so the odometry pose at the fix's time moves
  // towards the fix.
  const Pose2 believed = compose(correction_, *odometry);
  correction_.x += options_.positionGain * (position.x - believed.x);
  correction_.y += options_.positionGain * (position.y - believed.y);
  if (!lastFixTime_ || time > *lastFixTime_) lastFixTime_ = time;
  ++fixesUsed_;
  return true;
}

void Localizer::reset(const Pose2& pose) {
  if (history_.empty()) {
    correction_ = pose;
    return;
  }
  correction_ = compose(pose, inverse(history_.back().second));
  anchor_.reset();
}

bool Localizer::fixFresh() const {
  return lastFixTime_ && !history_.empty() &&
         history_.back().first - *lastFixTime_ <= options_.fixFreshness;
}

std::optional<PoseEstimate> Localizer::estimate() const {
  if (history_.empty()) return std::nullopt;
  return PoseEstimate{compose(correction_, history_.back().second),
                      fixFresh() ? PoseSource::Fix : PoseSource::Odometry, history_.back().first};
}

}  // namespace peis::nav
