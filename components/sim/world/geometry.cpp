// Plane geometry for the simulated home (geometry.h).
#include "sim/world/geometry.h"

#include <algorithm>

namespace peis::sim {

double normalizeAngle(double angle) {
  angle = std::remainder(angle, 2 * M_PI);
  return angle <= -M_PI ? angle + 2 * M_PI : angle;
}

bool insidePolygon(const Polygon& polygon, Vec2 point) {
  bool inside = false;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Vec2 a = polygon[i], b = polygon[j];
    if ((a.y > point.y) != (b.y > point.y) &&
        point.x < (b.x - a.x) * (point.y - a.y) / (b.y - a.y) + a.x)
      inside = !inside;
  }
  return inside;
}

double distanceToSegment(Vec2 point, Vec2 a, Vec2 b) {
  const Vec2 ab = b - a;
  const double length2 = ab.dot(ab);
  const double t = length2 > 0 ? std::clamp((point - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (point - (a + ab * t)).norm();
}

double distanceToBoundary(const Polygon& polygon, Vec2 point) {
  double best = INFINITY;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++)
    best = std::min(best, distanceToSegment(point, polygon[j], polygon[i]));
  return best;
}

std::optional<double> raySegment(Vec2 origin, Vec2 direction, Vec2 a, Vec2 b) {
  const Vec2 edge = b - a;
  const double denominator = direction.cross(edge);
  if (std::abs(denominator) < 1e-12) return std::nullopt;
  const Vec2 toA = a - origin;
  const double t = toA.cross(edge) / denominator;
  const double s = toA.cross(direction) / denominator;
  if (t < 0 || s < 0 || s > 1) return std::nullopt;
  return t;
}

bool segmentsIntersect(Vec2 p, Vec2 q, Vec2 a, Vec2 b) {
  const auto side = [](Vec2 o, Vec2 u, Vec2 v) { return (u - o).cross(v - o); };
  const double d1 = side(a, b, p), d2 = side(a, b, q), d3 = side(p, q, a), d4 = side(p, q, b);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
    return true;
  const auto onSegment = [](Vec2 o, Vec2 u, Vec2 v) {
    return std::min(o.x, u.x) - 1e-12 <= v.x && v.x <= std::max(o.x, u.x) + 1e-12 &&
           std::min(o.y, u.y) - 1e-12 <= v.y && v.y <= std::max(o.y, u.y) + 1e-12;
  };
  return (d1 == 0 && onSegment(a, b, p)) || (d2 == 0 && onSegment(a, b, q)) ||
         (d3 == 0 && onSegment(p, q, a)) || (d4 == 0 && onSegment(p, q, b));
}

Polygon thickSegment(Vec2 a, Vec2 b, double thickness) {
  Vec2 along = b - a;
  const double length = along.norm();
  along = length > 0 ? along * (1.0 / length) : Vec2{1, 0};
  // Extend by half the thickness at both ends so wall corners close.
  const Vec2 extend = along * (thickness / 2);
  const Vec2 side = Vec2{-along.y, along.x} * (thickness / 2);
  const Vec2 start = a - extend, end = b + extend;
  return {start - side, end - side, end + side, start + side};
}

Polygon box(Vec2 centre, Vec2 size, double theta) {
  const double c = std::cos(theta), s = std::sin(theta);
  Polygon corners;
  for (const Vec2 corner : {Vec2{-1, -1}, Vec2{1, -1}, Vec2{1, 1}, Vec2{-1, 1}}) {
    const double x = corner.x * size.x / 2, y = corner.y * size.y / 2;
    corners.push_back({centre.x + c * x - s * y, centre.y + s * x + c * y});
  }
  return corners;
}

double signedArea(const Polygon& polygon) {
  double area = 0;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++)
    area += polygon[j].cross(polygon[i]);
  return area / 2;
}

Vec2 centroid(const Polygon& polygon) {
  const double area = signedArea(polygon);
  if (std::abs(area) < 1e-12) {
    Vec2 mean;
    for (const Vec2 p : polygon) mean = mean + p;
    return polygon.empty() ? mean : mean * (1.0 / polygon.size());
  }
  Vec2 c;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const double f = polygon[j].cross(polygon[i]);
    c = c + (polygon[j] + polygon[i]) * f;
  }
  return c * (1.0 / (6 * area));
}

}  // namespace peis::sim
