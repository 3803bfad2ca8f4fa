// Planar poses and the few geometric helpers navigation needs: a pose in the
// map frame (x, y in metres, theta in radians counter-clockwise from +x),
// composition and inversion of rigid motions, and angle normalisation.
#pragma once

#include <cmath>
#include <numbers>

namespace peis::nav {

struct Point2 {
  double x = 0, y = 0;
  bool operator==(const Point2&) const = default;
};

struct Pose2 {
  double x = 0, y = 0, theta = 0;
  Point2 position() const { return {x, y}; }
  bool operator==(const Pose2&) const = default;
};

// An angle in (-pi, pi].
inline double normalizeAngle(double a) {
  a = std::remainder(a, 2 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2 * std::numbers::pi : a;
}

inline double distance(Point2 a, Point2 b) { return std::hypot(a.x - b.x, a.y - b.y); }

// a ⊕ b: the motion b expressed in a's frame, applied after a.
inline Pose2 compose(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, normalizeAngle(a.theta + b.theta)};
}

// ⊖a: the inverse motion, so that compose(inverse(a), a) is the identity.
inline Pose2 inverse(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, normalizeAngle(-a.theta)};
}

}  // namespace peis::nav
