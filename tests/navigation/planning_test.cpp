// Navigation core: map parsing, inflation (against a brute-force distance
// transform) and A* (against an exhaustive Dijkstra over every cell).
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <queue>
#include <random>

#include "astar.h"
#include "diff_drive_sim.h"

using namespace peis::nav;

namespace {

OccupancyGrid randomGrid(int w, int h, double density, unsigned seed) {
  OccupancyGrid grid(GridInfo{0.05, 0, 0, w, h});
  std::mt19937 rng(seed);
  std::bernoulli_distribution occupied(density);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) grid.setOccupied({x, y}, occupied(rng));
  return grid;
}

// Exhaustive: Dijkstra over every cell with the same moves and step costs.
double dijkstraCost(const Costmap& costmap, Cell start, Cell goal) {
  const auto& grid = costmap.grid();
  std::vector<double> dist(grid.cells().size(), std::numeric_limits<double>::infinity());
  using E = std::pair<double, int>;
  std::priority_queue<E, std::vector<E>, std::greater<>> q;
  dist[grid.index(start)] = 0;
  q.push({0, static_cast<int>(grid.index(start))});
  const int w = grid.width();
  while (!q.empty()) {
    auto [d, i] = q.top();
    q.pop();
    if (d > dist[i]) continue;
    const Cell c{i % w, i / w};
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        if (!dx && !dy) continue;
        const Cell n{c.x + dx, c.y + dy};
        if (costmap.lethal(n)) continue;
        if (dx && dy && (costmap.lethal({c.x + dx, c.y}) || costmap.lethal({c.x, c.y + dy})))
          continue;
        const double step = (dx && dy ? 1.41421356f : 1.0f) * 0.05f * costmap.stepFactor(n);
        const int ni = static_cast<int>(grid.index(n));
        if (d + step < dist[ni]) {
          dist[ni] = d + step;
          q.push({dist[ni], ni});
        }
      }
  }
  return dist[grid.index(goal)];
}

}  // namespace

TEST_CASE("map.info and the PGM map are read and checked", "[unit]") {
  const GridInfo info = parseMapInfo("0.05 -1.0 2.5 4 3");
  CHECK(info.resolution == 0.05);
  CHECK(info.originX == -1.0);
  CHECK(info.width == 4);
  CHECK(info.height == 3);
  OccupancyGrid grid(info);
  grid.setOccupied({0, 0}, true);  // bottom left
  grid.setOccupied({3, 2}, true);  // top right
  const std::string pgm = toPgm(grid);
  // Row 0 of the PGM is the top: its last pixel is the top-right cell.
  CHECK(pgm.substr(pgm.size() - 12, 4) == std::string("\xff\xff\xff\x00", 4));
  const OccupancyGrid back = parsePgmMap(pgm, info);
  CHECK(back.cells() == grid.cells());
  CHECK(back.cellOf({-0.99, 2.51}) == Cell{0, 0});
  CHECK(back.centreOf({0, 0}).x == Approx(-0.975));

  CHECK_THROWS_WITH(parseMapInfo("0.05 0 0 4"), Catch::Contains("got 4 fields"));
  CHECK_THROWS_WITH(parseMapInfo("x 0 0 4 3"), Catch::Contains("RESOLUTION 'x' is not a number"));
  CHECK_THROWS_WITH(parseMapInfo("0.05 0 0 4.5 3"), Catch::Contains("whole numbers"));
  CHECK_THROWS_WITH(parseMapInfo("-1 0 0 4 3"), Catch::Contains("positive"));
  CHECK_THROWS_WITH(parsePgmMap("P2\n4 3\n255\n", info), Catch::Contains("not a binary PGM"));
  CHECK_THROWS_WITH(parsePgmMap("P5\n5 3\n255\n" + std::string(15, '\xff'), info),
                    Catch::Contains("5x3 cells but map.info says 4x3"));
  CHECK_THROWS_WITH(parsePgmMap("P5\n4 3\n255\n" + std::string(11, '\xff'), info),
                    Catch::Contains("11 bytes of pixels, 12 expected"));
  CHECK_THROWS_WITH(parsePgmMap("P5\n4 x\n255\n", info), Catch::Contains("height 'x'"));
  CHECK_THROWS_WITH(parsePgmMap("P5\n4 3\n65535\n", info), Catch::Contains("16-bit"));
  CHECK_THROWS_WITH(parsePgmMap("P5\n# a comment\n4 3\n255", info),
                    Catch::Contains("no pixel data"));
}

TEST_CASE("the distance transform is exact (against brute force)", "[unit]") {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const OccupancyGrid grid = randomGrid(23, 17, 0.03, seed);
    const auto dt = distanceTransform(grid);
    for (int y = 0; y < grid.height(); ++y)
      for (int x = 0; x < grid.width(); ++x) {
        double best = std::numeric_limits<double>::infinity();
        for (int oy = 0; oy < grid.height(); ++oy)
          for (int ox = 0; ox < grid.width(); ++ox)
            if (grid.occupied({ox, oy})) best = std::min(best, std::hypot(ox - x, oy - y));
        if (std::isinf(best)) continue;
        REQUIRE(dt[grid.index({x, y})] == Approx(best).margin(1e-4));
      }
  }
}

TEST_CASE("inflation makes lethal exactly the cells within radius plus margin", "[unit]") {
  OccupancyGrid grid(GridInfo{0.05, 0, 0, 40, 40});
  grid.setOccupied({20, 20}, true);
  const Costmap costmap(grid, InflationOptions{0.2, 0.02, 0.25, 2.0});
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) {
      const double d = std::hypot(x - 20, y - 20) * 0.05;
      REQUIRE(costmap.lethal({x, y}) == (d < 0.22));
      if (d >= 0.22 + 0.25) REQUIRE(costmap.stepFactor({x, y}) == 1.0f);
      if (d >= 0.22 && d < 0.47) REQUIRE(costmap.stepFactor({x, y}) > 1.0f);
    }
  CHECK(costmap.lethal({-1, 3}));  // outside the grid
}

TEST_CASE("A* finds the cheapest path (against exhaustive Dijkstra)", "[unit]") {
  std::mt19937 rng(7);
  int compared = 0;
  for (unsigned seed = 1; seed <= 30; ++seed) {
    const OccupancyGrid grid = randomGrid(40, 30, 0.02, seed);
    const Costmap costmap(grid, InflationOptions{0.06, 0.0, 0.1, 2.0});
    std::uniform_int_distribution<int> ux(0, 39), uy(0, 29);
    Cell start{ux(rng), uy(rng)}, goal{ux(rng), uy(rng)};
    if (costmap.lethal(start) || costmap.lethal(goal)) continue;
    const PlannedPath path = planPath(costmap, grid.centreOf(start), grid.centreOf(goal));
    const double best = dijkstraCost(costmap, start, goal);
    if (std::isinf(best)) {
      CHECK(path.failure == PlanFailure::NoPath);
      continue;
    }
    REQUIRE(path.found());
    ++compared;
    CHECK(path.cost == Approx(best).epsilon(1e-4));
    CHECK(path.cells.front() == start);
    CHECK(path.cells.back() == goal);
    for (std::size_t i = 0; i < path.cells.size(); ++i) {
      REQUIRE_FALSE(costmap.lethal(path.cells[i]));
      if (i)
        REQUIRE(std::max(std::abs(path.cells[i].x - path.cells[i - 1].x),
                         std::abs(path.cells[i].y - path.cells[i - 1].y)) == 1);
    }
    for (std::size_t i = 1; i < path.waypoints.size(); ++i)
      REQUIRE(segmentFree(costmap, path.waypoints[i - 1], path.waypoints[i]));
  }
  CHECK(compared >= 15);
}

TEST_CASE("planning failures are named: no path, outside the map, goal blocked", "[unit]") {
  const OccupancyGrid home = test::smallHome();
  const Costmap costmap(home, InflationOptions{0.2, 0.02, 0.25, 2.0});
  const PlannedPath through = planPath(costmap, {1.0, 1.0}, {5.0, 3.0});
  REQUIRE(through.found());
  CHECK(through.length > distance({1.0, 1.0}, {5.0, 3.0}));
  CHECK(through.waypoints.size() >= 3);  // it bends through the door

  OccupancyGrid closed = home;
  for (int y = 30; y < 50; ++y) closed.setOccupied({60, y}, true);  // door shut
  const Costmap shut(closed, InflationOptions{0.2, 0.02, 0.25, 2.0});
  CHECK(planPath(shut, {1.0, 1.0}, {5.0, 3.0}).failure == PlanFailure::NoPath);
  CHECK(std::string(toString(PlanFailure::NoPath)) == "no path");
  CHECK(planPath(costmap, {-1.0, 1.0}, {5.0, 3.0}).failure == PlanFailure::StartOutsideMap);
  CHECK(planPath(costmap, {1.0, 1.0}, {5.0, 30.0}).failure == PlanFailure::GoalOutsideMap);
  CHECK(planPath(costmap, {1.0, 1.0}, {3.0, 0.5}).failure == PlanFailure::GoalBlocked);
  // A robot pressed against a wall leaves by the nearest free cell.
  const PlannedPath escape = planPath(costmap, {1.0, 0.2}, {1.0, 2.0});
  REQUIRE(escape.found());
  CHECK(escape.waypoints.front().y == Approx(0.2));
  // A robot inside a wall cannot.
  CHECK(planPath(costmap, {3.0, 0.5}, {1.0, 2.0}).failure == PlanFailure::StartBlocked);
}

TEST_CASE("an obstacle added to the costmap blocks the cells around it", "[unit]") {
  const OccupancyGrid home = test::smallHome();
  Costmap costmap(home, InflationOptions{0.2, 0.02, 0.25, 2.0});
  CHECK_FALSE(costmap.lethal(home.cellOf({1.5, 2.0})));
  costmap.addObstacle({1.5, 2.0}, 0.1);
  CHECK(costmap.grid().occupied(home.cellOf({1.5, 2.0})));
  CHECK(costmap.lethal(home.cellOf({1.5, 2.25})));
  CHECK_FALSE(costmap.lethal(home.cellOf({1.5, 2.45})));
  // The same costs as a costmap built with the obstacle from the start.
  const Costmap rebuilt(costmap.grid(), costmap.options());
  for (int y = 0; y < home.height(); ++y)
    for (int x = 0; x < home.width(); ++x) {
      REQUIRE(costmap.lethal({x, y}) == rebuilt.lethal({x, y}));
      REQUIRE(costmap.stepFactor({x, y}) == Approx(rebuilt.stepFactor({x, y})).margin(1e-5));
    }
}
