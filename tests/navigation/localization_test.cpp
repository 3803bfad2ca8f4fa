// Navigation core: the localization switch (fixes when fresh, dead reckoning
// from the last good fix otherwise) and the path follower.
#include <catch2/catch.hpp>
#include <cmath>

#include "diff_drive_sim.h"
#include "localizer.h"
#include "path_follower.h"

using namespace peis::nav;

TEST_CASE("pose helpers compose and invert", "[unit]") {
  const Pose2 a{1, 2, 0.5}, b{0.3, -0.2, -1.0};
  const Pose2 ab = compose(a, b);
  const Pose2 back = compose(inverse(a), ab);
  CHECK(back.x == Approx(b.x));
  CHECK(back.y == Approx(b.y));
  CHECK(back.theta == Approx(b.theta));
  CHECK(normalizeAngle(3 * std::numbers::pi) == Approx(std::numbers::pi));
  CHECK(normalizeAngle(-std::numbers::pi) == Approx(std::numbers::pi));
}

TEST_CASE("without fixes the localizer is odometry", "[unit]") {
  Localizer localizer;
  CHECK_FALSE(localizer.estimate());
  localizer.onOdometry({1, 2, 0.3}, 10.0);
  const auto e = localizer.estimate();
  REQUIRE(e);
  CHECK(e->source == PoseSource::Odometry);
  CHECK(e->pose == Pose2{1, 2, 0.3});
}

TEST_CASE("fixes correct drifting odometry; stale fixes leave dead reckoning from the last one",
          "[unit]") {
  // The robot drives straight along +x from (0, 0); its odometry believes it
  // started at (0.5, -0.4) heading 0.2 rad off.
  Localizer localizer;
  const Pose2 odometryFrame{0.5, -0.4, 0.2};  // map <- odometry, the error to find
  const Pose2 toOdometry = inverse(odometryFrame);
  double t = 100;
  for (int i = 0; i <= 300; ++i, t += 0.05) {
    const Pose2 truth{0.01 * i, 0, 0};
    localizer.onOdometry(compose(toOdometry, truth), t);
    if (i % 2 == 0) localizer.onFix(truth.position(), t);
  }
  auto e = localizer.estimate();
  REQUIRE(e);
  CHECK(e->source == PoseSource::Fix);
  CHECK(e->pose.x == Approx(3.0).margin(0.01));
  CHECK(e->pose.y == Approx(0.0).margin(0.01));
  CHECK(e->pose.theta == Approx(0.0).margin(0.03));

  // The fixes stop (out of the cameras' view): after the freshness the
  // source is odometry, and the pose keeps following the wheels from there.
  for (int i = 301; i <= 400; ++i, t += 0.05)
    localizer.onOdometry(compose(toOdometry, Pose2{0.01 * i, 0, 0}), t);
  e = localizer.estimate();
  REQUIRE(e);
  CHECK(e->source == PoseSource::Odometry);
  CHECK_FALSE(localizer.fixFresh());
  CHECK(e->pose.x == Approx(4.0).margin(0.03));
  CHECK(e->pose.y == Approx(0.0).margin(0.03));

  // Fixes come back: fix-based again at once.
  localizer.onFix({4.0, 0.0}, t - 0.05);
  CHECK(localizer.estimate()->source == PoseSource::Fix);
}

TEST_CASE("fixes from before the odometry history, or from the future, are ignored", "[unit]") {
  Localizer localizer;
  CHECK_FALSE(localizer.onFix({1, 1}, 5.0));  // no odometry yet
  for (int i = 0; i < 100; ++i) localizer.onOdometry({0, 0, 0}, 10.0 + 0.05 * i);
  CHECK_FALSE(localizer.onFix({1, 1}, 1.0));
  CHECK_FALSE(localizer.onFix({1, 1}, 100.0));
  CHECK_FALSE(localizer.onFix({std::nan(""), 1}, 14.0));
  CHECK(localizer.estimate()->pose == Pose2{0, 0, 0});
  CHECK(localizer.onFix({1, 1}, 14.0));
  CHECK(localizer.fixesUsed() == 1);
}

TEST_CASE("the path follower brings a robot to the goal and its heading", "[unit]") {
  test::DiffDriveSim robot({0.5, 0.5, 0}, 0.2);
  PathFollower follower;
  follower.setPath({{0.5, 0.5}, {2.0, 0.5}, {2.0, 2.0}, {0.8, 2.5}}, std::numbers::pi / 2);
  int steps = 0;
  while (!follower.arrived() && steps < 4000) {
    robot.step(follower.update(robot.truth()), 0.05);
    ++steps;
  }
  REQUIRE(follower.arrived());
  CHECK(distance(robot.truth().position(), {0.8, 2.5}) < 0.05);
  CHECK(std::abs(normalizeAngle(robot.truth().theta - std::numbers::pi / 2)) < 0.12);
  CHECK(follower.update(robot.truth()) == VelocityCommand{0, 0});
}

TEST_CASE("a robot behind the goal turns round instead of driving away", "[unit]") {
  test::DiffDriveSim robot({1.0, 1.0, 0}, 0.2);
  PathFollower follower;
  follower.setPath({{1.0, 1.0}, {0.0, 1.0}}, std::nullopt);
  const VelocityCommand first = follower.update(robot.truth());
  CHECK(first.v == 0);
  CHECK(std::abs(first.w) > 0);
  int steps = 0;
  while (!follower.arrived() && steps < 2000) {
    robot.step(follower.update(robot.truth()), 0.05);
    ++steps;
  }
  CHECK(follower.arrived());
  CHECK(distance(robot.truth().position(), {0.0, 1.0}) < 0.05);
}
