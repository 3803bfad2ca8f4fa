// Test helper: a differential-drive robot on a plane, for closed-loop tests
// of navigation without a network: integrates (v, w) commands with
// acceleration limits, keeps noisy odometry, and reports bumper and sonar
// readings against a list of disk obstacles and an occupancy grid.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "occupancy_grid.h"
#include "path_follower.h"
#include "pose.h"

namespace peis::nav::test {

struct Disk {
  Point2 centre;
  double radius;
};

class DiffDriveSim {
 public:
  DiffDriveSim(Pose2 start, double radius, unsigned seed = 1)
      : truth_(start), odometry_(start), radius_(radius), rng_(seed) {}

  double odometryNoise = 0;             // standard deviation per metre, translation and rotation
  double headingDrift = 0;              // radians per metre of systematic drift
  const OccupancyGrid* grid = nullptr;  // walls for collisions and sonar
  std::vector<Disk> obstacles;
  // Like peis-sim-world's bases: the bumper, once pressed, stays pressed
  // until the robot moves again (turning in place does not release it).
  bool latchBumper = false;

  // One step of dt seconds towards the command.
  void step(VelocityCommand command, double dt) {
    const double maxAccel = 1.0, maxAngularAccel = 3.0;
    v_ += std::clamp(command.v - v_, -maxAccel * dt, maxAccel * dt);
    w_ += std::clamp(command.w - w_, -maxAngularAccel * dt, maxAngularAccel * dt);
    const double ds = v_ * dt, dth = w_ * dt;
    Pose2 next = truth_;
    next.x += ds * std::cos(truth_.theta + dth / 2);
    next.y += ds * std::sin(truth_.theta + dth / 2);
    next.theta = normalizeAngle(truth_.theta + dth);
    const bool blocked = collides(next.position());
    const bool translates = std::abs(ds) > 1e-12;
    bumper_ = blocked || (latchBumper && bumper_ && !translates);
    if (blocked) {
      next.x = truth_.x;
      next.y = truth_.y;
      v_ = 0;
    }
    const double moved = distance(truth_.position(), next.position());
    std::normal_distribution<double> n(0, 1);
    const double odoDs = (blocked ? 0 : ds) * (1 + odometryNoise * n(rng_));
    const double odoDth = dth + odometryNoise * std::abs(dth) * n(rng_) + headingDrift * moved;
    odometry_.x += odoDs * std::cos(odometry_.theta + odoDth / 2);
    odometry_.y += odoDs * std::sin(odometry_.theta + odoDth / 2);
    odometry_.theta = normalizeAngle(odometry_.theta + odoDth);
    truth_ = next;
    time_ += dt;
  }

  bool collides(Point2 p) const {
    for (const auto& d : obstacles)
      if (distance(p, d.centre) < radius_ + d.radius) return true;
    if (grid) {
      const double res = grid->info().resolution;
      const Cell c = grid->cellOf(p);
      const int r = static_cast<int>(std::ceil(radius_ / res)) + 1;
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          const Cell o{c.x + dx, c.y + dy};
          if (!grid->inside(o)) continue;
          if (grid->occupied(o) && distance(grid->centreOf(o), p) < radius_ + res * 0.5)
            return true;
        }
    }
    return false;
  }

  // Ranges from the rim at the given angles, up to maxRange (ray marching).
  std::vector<double> sonar(const std::vector<double>& angles, double maxRange) const {
    std::vector<double> out;
    for (double a : angles) {
      double r = 0;
      for (; r < maxRange; r += 0.01) {
        const double d = radius_ + r;
        const Point2 p{truth_.x + d * std::cos(truth_.theta + a),
                       truth_.y + d * std::sin(truth_.theta + a)};
        bool hit = false;
        for (const auto& o : obstacles) hit = hit || distance(p, o.centre) < o.radius;
        if (grid && (!grid->contains(p) || grid->occupied(grid->cellOf(p)))) hit = true;
        if (hit) break;
      }
      out.push_back(std::min(r, maxRange));
    }
    return out;
  }

  const Pose2& truth() const { return truth_; }
  const Pose2& odometry() const { return odometry_; }
  bool bumper() const { return bumper_; }
  double time() const { return time_; }

 private:
  Pose2 truth_, odometry_;
  double radius_;
  double v_ = 0, w_ = 0;
  bool bumper_ = false;
  double time_ = 1000.0;
  std::mt19937 rng_;
};

// A small home: 6 x 4 m, a wall at x = 3 with a 1 m door at y 1.5..2.5.
inline OccupancyGrid smallHome() {
  OccupancyGrid grid(GridInfo{0.05, 0, 0, 120, 80});
  for (int x = 0; x < 120; ++x) {
    grid.setOccupied({x, 0}, true);
    grid.setOccupied({x, 79}, true);
  }
  for (int y = 0; y < 80; ++y) {
    grid.setOccupied({0, y}, true);
    grid.setOccupied({119, y}, true);
    if (y < 30 || y >= 50) {
      grid.setOccupied({59, y}, true);
      grid.setOccupied({60, y}, true);
    }
  }
  return grid;
}

}  // namespace peis::nav::test
