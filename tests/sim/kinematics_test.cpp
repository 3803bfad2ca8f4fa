// Unit tests of differential-drive kinematics and odometry noise
// (sim/world/kinematics.h).
#include "sim/world/kinematics.h"

#include <catch2/catch.hpp>
#include <cmath>

using namespace peis::sim;

TEST_CASE("integrate drives straight lines and exact arcs", "[unit]") {
  const Pose2 straight = integrate({1, 2, 0}, {0.5, 0}, 2.0);
  CHECK(straight.x == Approx(2.0));
  CHECK(straight.y == Approx(2.0));
  // Radius 1 m: half a circle in pi seconds ends 2 m to the left, turned round.
  const Pose2 half = integrate({0, 0, 0}, {0.5, 0.5}, M_PI / 0.5);
  CHECK(half.x == Approx(0.0).margin(1e-9));
  CHECK(half.y == Approx(2.0));
  CHECK(std::abs(half.theta) == Approx(M_PI));
  // Many small steps give the same arc as one big one.
  Pose2 stepped{0, 0, 0};
  for (int i = 0; i < 1000; ++i) stepped = integrate(stepped, {0.5, 0.5}, M_PI / 0.5 / 1000);
  CHECK(stepped.x == Approx(half.x).margin(1e-9));
  CHECK(stepped.y == Approx(half.y));
  // Turning in place.
  const Pose2 turned = integrate({1, 1, 0}, {0, 1}, 1.0);
  CHECK(turned.x == 1);
  CHECK(turned.theta == Approx(1.0));
}

TEST_CASE("commands are clamped and velocities follow them within the acceleration limits",
          "[unit]") {
  const DriveLimits limits{0.5, 1.0, 1.0, 2.0};
  CHECK(clampCommand({2, -3}, limits) == Velocity{0.5, -1.0});
  Velocity v{};
  v = approach(v, {0.5, 1.0}, limits, 0.1);
  CHECK(v.v == Approx(0.1));
  CHECK(v.w == Approx(0.2));
  for (int i = 0; i < 100; ++i) v = approach(v, {5, 5}, limits, 0.1);
  CHECK(v.v == Approx(0.5));
  CHECK(v.w == Approx(1.0));
  v = approach(v, {0, 0}, limits, 0.1);
  CHECK(v.v == Approx(0.4));
}

TEST_CASE("odometry noise has the configured spread and none without noise", "[unit]") {
  std::mt19937 rng(7);
  const OdometryStep truth{1.0, 0.5};
  const OdometryStep exact = noisy(truth, {0, 0, 0}, rng);
  CHECK(exact.distance == 1.0);
  CHECK(exact.turn == 0.5);
  const OdometryNoise noise{0.02, 0.04, 0.01};
  double sumD = 0, sumD2 = 0, sumT = 0, sumT2 = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const auto s = noisy(truth, noise, rng);
    sumD += s.distance, sumD2 += s.distance * s.distance;
    sumT += s.turn, sumT2 += s.turn * s.turn;
  }
  const double meanD = sumD / n, meanT = sumT / n;
  CHECK(meanD == Approx(1.0).margin(0.001));
  CHECK(std::sqrt(sumD2 / n - meanD * meanD) == Approx(0.02).epsilon(0.05));
  CHECK(meanT == Approx(0.5).margin(0.001));
  CHECK(std::sqrt(sumT2 / n - meanT * meanT) == Approx(0.04 * 0.5 + 0.01 * 1.0).epsilon(0.05));
}

TEST_CASE("accumulate turns half before and half after the move", "[unit]") {
  const Pose2 p = accumulate({0, 0, 0}, {1.0, M_PI / 2});
  CHECK(p.x == Approx(std::cos(M_PI / 4)));
  CHECK(p.y == Approx(std::sin(M_PI / 4)));
  CHECK(p.theta == Approx(M_PI / 2));
  CHECK(normalizeAngle(3 * M_PI) == Approx(M_PI));
  CHECK(normalizeAngle(-M_PI) == Approx(M_PI));
}
