// Coverage lanes and the push-or-avoid decision (see coverage.h).
#include "coverage.h"

#include <algorithm>
#include <cmath>

#include "execution/exec_server.h"

namespace peis::devices {

std::optional<std::vector<Point2>> parsePolygon(std::string_view text) {
  const auto numbers = exec::parseNumbers(text);
  if (!numbers || numbers->size() < 6 || numbers->size() % 2) return std::nullopt;
  std::vector<Point2> polygon;
  for (std::size_t i = 0; i < numbers->size(); i += 2)
    polygon.push_back({(*numbers)[i], (*numbers)[i + 1]});
  return polygon;
}

bool insidePolygon(const std::vector<Point2>& polygon, Point2 p) {
  bool inside = false;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Point2 a = polygon[i], b = polygon[j];
    if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x)
      inside = !inside;
  }
  return inside;
}

std::vector<Point2> coverageWaypoints(const nav::Costmap& costmap, const std::vector<Point2>& room,
                                      double spacing) {
  std::vector<Point2> out;
  if (room.size() < 3 || !(spacing > 0)) return out;
  double minX = room[0].x, maxX = room[0].x, minY = room[0].y, maxY = room[0].y;
  for (const auto& p : room) {
    minX = std::min(minX, p.x);
    maxX = std::max(maxX, p.x);
    minY = std::min(minY, p.y);
    maxY = std::max(maxY, p.y);
  }
  const auto& grid = costmap.grid();
  const double step = grid.info().resolution;
  bool forward = true;
  for (double y = minY + spacing / 2; y < maxY; y += spacing) {
    std::vector<std::pair<Point2, Point2>> runs;
    std::optional<Point2> start;
    Point2 last{};
    for (double x = minX + step / 2; x < maxX; x += step) {
      const Point2 p{x, y};
      const bool free = insidePolygon(room, p) && !costmap.lethal(grid.cellOf(p));
      if (free && !start) start = p;
      if (!free && start) {
        runs.push_back({*start, last});
        start.reset();
      }
      if (free) last = p;
    }
    if (start) runs.push_back({*start, last});
    if (!forward) {
      std::reverse(runs.begin(), runs.end());
      for (auto& run : runs) std::swap(run.first, run.second);
    }
    for (const auto& [a, b] : runs) {
      out.push_back(a);
      if (nav::distance(a, b) > step) out.push_back(b);
    }
    if (!runs.empty()) forward = !forward;
  }
  return out;
}

ObstacleDecision decideObstacle(std::optional<long> grams, double pushLimitKg) {
  const long limit = std::lround(pushLimitKg * 1000);
  if (!grams) return {false, "avoid: weight unknown"};
  if (*grams <= limit)
    return {true, "push: " + std::to_string(*grams) + " g <= " + std::to_string(limit) + " g"};
  return {false, "avoid: " + std::to_string(*grams) + " g > " + std::to_string(limit) + " g"};
}

}  // namespace peis::devices
