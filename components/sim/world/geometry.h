// Plane geometry for the simulated home: points, poses, polygons and the
// few tests the world needs (inside, distance to a segment, ray hits).
// Pure functions on value types.
#pragma once

#include <cmath>
#include <optional>
#include <vector>

namespace peis::sim {

struct Vec2 {
  double x = 0, y = 0;
  Vec2 operator+(Vec2 o) const { return {x + o.x, y + o.y}; }
  Vec2 operator-(Vec2 o) const { return {x - o.x, y - o.y}; }
  Vec2 operator*(double s) const { return {x * s, y * s}; }
  double dot(Vec2 o) const { return x * o.x + y * o.y; }
  double cross(Vec2 o) const { return x * o.y - y * o.x; }
  double norm() const { return std::hypot(x, y); }
  bool operator==(const Vec2&) const = default;
};

// A pose in the map frame: position and heading (radians, counter-clockwise from +x).
struct Pose2 {
  double x = 0, y = 0, theta = 0;
  Vec2 position() const { return {x, y}; }
  bool operator==(const Pose2&) const = default;
};

using Polygon = std::vector<Vec2>;

// Wraps an angle into (-pi, pi].
double normalizeAngle(double angle);
bool insidePolygon(const Polygon& polygon, Vec2 point);
double distanceToSegment(Vec2 point, Vec2 a, Vec2 b);
// Distance from `point` to the polygon's boundary.
double distanceToBoundary(const Polygon& polygon, Vec2 point);
// Parameter t >= 0 along origin + t * direction where the ray first meets
// segment [a, b]; nullopt if it does not.
std::optional<double> raySegment(Vec2 origin, Vec2 direction, Vec2 a, Vec2 b);
// True if segments [p, q] and [a, b] cross (touching counts).
bool segmentsIntersect(Vec2 p, Vec2 q, Vec2 a, Vec2 b);
// The rectangle of a wall segment [a, b] with a thickness, as a polygon.
Polygon thickSegment(Vec2 a, Vec2 b, double thickness);
// A box centred at `centre`, `size` (width along the heading, depth), turned by `theta`.
Polygon box(Vec2 centre, Vec2 size, double theta);
Vec2 centroid(const Polygon& polygon);
double signedArea(const Polygon& polygon);

}  // namespace peis::sim
