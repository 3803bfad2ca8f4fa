// A* on the inflated grid, and the shortening of its cell path into waypoints.
#include "astar.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <queue>

namespace peis::nav {

const char* toString(PlanFailure failure) {
  switch (failure) {
    case PlanFailure::None:
      return "none";
    case PlanFailure::StartOutsideMap:
      return "robot outside the map";
    case PlanFailure::GoalOutsideMap:
      return "goal outside the map";
    case PlanFailure::StartBlocked:
      return "robot in an obstacle";
    case PlanFailure::GoalBlocked:
      return "goal blocked";
    case PlanFailure::NoPath:
      return "no path";
  }
  return "unknown";
}

namespace {

constexpr float kSqrt2 = 1.41421356f;

// The nearest non-lethal cell within `radius` metres (breadth first), or
// nothing.
std::optional<Cell> nearestFree(const Costmap& costmap, Cell from, double radius) {
  const auto& grid = costmap.grid();
  const int reach = static_cast<int>(std::ceil(radius / grid.info().resolution));
  std::optional<Cell> best;
  double bestDistance = std::numeric_limits<double>::infinity();
  for (int dy = -reach; dy <= reach; ++dy)
    for (int dx = -reach; dx <= reach; ++dx) {
      const Cell c{from.x + dx, from.y + dy};
      const double d = std::hypot(dx, dy) * grid.info().resolution;
      if (d > radius || d >= bestDistance || costmap.lethal(c)) continue;
      best = c;
      bestDistance = d;
    }
  return best;
}

// Along the segment: the largest step factor, or infinity if a cell is lethal.
float worstFactorAlong(const Costmap& costmap, Point2 a, Point2 b) {
  const auto& grid = costmap.grid();
  const double length = distance(a, b);
  const int steps =
      std::max(1, static_cast<int>(std::ceil(length / (grid.info().resolution * 0.5))));
  float worst = 1.0f;
  for (int i = 0; i <= steps; ++i) {
    const double t = double(i) / steps;
    const Cell c = grid.cellOf({a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t});
    if (costmap.lethal(c)) return std::numeric_limits<float>::infinity();
    worst = std::max(worst, costmap.stepFactor(c));
  }
  return worst;
}

std::vector<Point2> shorten(const Costmap& costmap, const std::vector<Cell>& cells, Point2 start,
                            Point2 goal) {
  const auto& grid = costmap.grid();
  std::vector<Point2> points;
  points.reserve(cells.size());
  for (const Cell& c : cells) points.push_back(grid.centreOf(c));
  points.front() = start;
  points.back() = goal;
  std::vector<Point2> out{points.front()};
  std::size_t anchor = 0;
  while (anchor + 1 < points.size()) {
    // The furthest point reachable in a straight line, scanning forward until
    // a line fails; the line may not pass nearer the walls than the A* path
    // between the two points did.
    std::size_t next = anchor + 1;
    float pathWorst = costmap.lethal(cells[anchor]) ? 1.0f : costmap.stepFactor(cells[anchor]);
    for (std::size_t j = anchor + 1; j < points.size(); ++j) {
      if (!costmap.lethal(cells[j])) pathWorst = std::max(pathWorst, costmap.stepFactor(cells[j]));
      const float lineWorst = worstFactorAlong(costmap, points[anchor], points[j]);
      if (lineWorst > pathWorst + 1e-4f) {
        if (j > anchor + 1) break;
        next = j;  // a neighbour is always kept (it is how A* went)
        break;
      }
      next = j;
    }
    out.push_back(points[next]);
    anchor = next;
  }
  return out;
}

}  // namespace

bool segmentFree(const Costmap& costmap, Point2 a, Point2 b) {
  return std::isfinite(worstFactorAlong(costmap, a, b));
}

PlannedPath planPath(const Costmap& costmap, Point2 start, Point2 goal,
                     const PlanOptions& options) {
  PlannedPath result;
  const auto& grid = costmap.grid();
  Cell startCell = grid.cellOf(start);
  Cell goalCell = grid.cellOf(goal);
  if (!grid.inside(startCell)) {
    result.failure = PlanFailure::StartOutsideMap;
    return result;
  }
  if (!grid.inside(goalCell)) {
    result.failure = PlanFailure::GoalOutsideMap;
    return result;
  }
  std::vector<Cell> prefix;  // the way out of a lethal start
  if (costmap.lethal(startCell)) {
    const auto free = nearestFree(costmap, startCell, options.startEscape);
    if (!free || grid.occupied(startCell)) {
      result.failure = PlanFailure::StartBlocked;
      return result;
    }
    prefix.push_back(startCell);
    startCell = *free;
  }
  if (costmap.lethal(goalCell)) {
    const auto free = nearestFree(costmap, goalCell, options.goalTolerance);
    if (!free) {
      result.failure = PlanFailure::GoalBlocked;
      return result;
    }
    goalCell = *free;
    goal = grid.centreOf(goalCell);
  }

  const int w = grid.width();
  const std::size_t n = grid.cells().size();
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> g(n, inf);
  std::vector<std::int32_t> parent(n, -1);
  std::vector<std::uint8_t> closed(n, 0);
  auto heuristic = [&](Cell c) {
    const float dx = std::abs(c.x - goalCell.x), dy = std::abs(c.y - goalCell.y);
    return static_cast<float>(grid.info().resolution) *
           (std::max(dx, dy) + (kSqrt2 - 1.0f) * std::min(dx, dy));
  };
  using Entry = std::pair<float, std::int32_t>;  // (f, index)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  const std::size_t startIndex = grid.index(startCell), goalIndex = grid.index(goalCell);
  g[startIndex] = 0;
  open.push({heuristic(startCell), static_cast<std::int32_t>(startIndex)});
  const float res = static_cast<float>(grid.info().resolution);
  static constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static constexpr int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  while (!open.empty()) {
    const auto [f, index] = open.top();
    open.pop();
    if (closed[index]) continue;
    closed[index] = 1;
    ++result.expanded;
    if (static_cast<std::size_t>(index) == goalIndex) break;
    const Cell c{index % w, index / w};
    for (int k = 0; k < 8; ++k) {
      const Cell nb{c.x + kDx[k], c.y + kDy[k]};
      if (costmap.lethal(nb)) continue;
      const bool diagonal = k >= 4;
      if (diagonal && (costmap.lethal({c.x + kDx[k], c.y}) || costmap.lethal({c.x, c.y + kDy[k]})))
        continue;
      const std::size_t ni = grid.index(nb);
      if (closed[ni]) continue;
      const float step = (diagonal ? kSqrt2 : 1.0f) * res * costmap.stepFactor(nb);
      const float candidate = g[index] + step;
      if (candidate < g[ni]) {
        g[ni] = candidate;
        parent[ni] = index;
        open.push({candidate + heuristic(nb), static_cast<std::int32_t>(ni)});
      }
    }
  }
  if (!closed[goalIndex]) {
    result.failure = PlanFailure::NoPath;
    return result;
  }
  result.cost = g[goalIndex];
  std::vector<Cell> cells;
  for (std::int32_t i = static_cast<std::int32_t>(goalIndex); i >= 0; i = parent[i])
    cells.push_back({i % w, i / w});
  cells.insert(cells.end(), prefix.rbegin(), prefix.rend());
  std::reverse(cells.begin(), cells.end());
  result.cells = std::move(cells);
  if (options.shorten && result.cells.size() > 1) {
    result.waypoints = shorten(costmap, result.cells, start, goal);
  } else {
    result.waypoints = {start, goal};
  }
  for (std::size_t i = 1; i < result.waypoints.size(); ++i)
    result.length += distance(result.waypoints[i - 1], result.waypoints[i]);
  return result;
}

}  // namespace peis::nav
