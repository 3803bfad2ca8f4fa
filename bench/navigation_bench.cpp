// Navigation benchmark (./run bench, docs/performance.md): planning time on
// the PEIS-Home's map (as the world publishes it) and on a 2,000 x 2,000 cell
// map, and the final position error at the goal of the navigation core in
// closed loop with a simulated robot whose odometry has the home's noise,
// with position fixes of the tracker's measured accuracy and with odometry
// only.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "astar.h"
#include "navigator.h"
#include "sim/world/occupancy_grid.h"

using namespace peis::nav;
using Clock = std::chrono::steady_clock;

namespace {

double ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5))];
}

OccupancyGrid homeMap() {
  const auto world = peis::sim::loadWorldFile(std::string(PEIS_SOURCE_DIR) +
                                              "/components/sim/homes/peis-home.yaml");
  const auto grid = peis::sim::OccupancyGrid::fromWorld(world);
  return parsePgmMap(grid.toPgm(), parseMapInfo(grid.info()));
}

// 100 x 100 m at 5 cm: rooms of 10 m with a 1.2 m door in each wall, and
// random pieces of furniture.
OccupancyGrid bigMap() {
  OccupancyGrid grid(GridInfo{0.05, 0, 0, 2000, 2000});
  std::mt19937 rng(5);
  for (int i = 0; i < 2000; ++i)
    for (int wall = 0; wall < 2000; wall += 200)
      for (int t = 0; t < 3; ++t) {
        const bool door = (i % 200) >= 80 && (i % 200) < 104;
        if (!door) {
          grid.setOccupied({wall + t, i}, true);
          grid.setOccupied({i, wall + t}, true);
        }
      }
  std::uniform_int_distribution<int> pos(0, 1990), size(4, 24);
  for (int k = 0; k < 1500; ++k) {
    const int x = pos(rng), y = pos(rng), w = size(rng), h = size(rng);
    for (int dy = 0; dy < h && y + dy < 2000; ++dy)
      for (int dx = 0; dx < w && x + dx < 2000; ++dx) grid.setOccupied({x + dx, y + dy}, true);
  }
  return grid;
}

void planningTable() {
  std::printf(
      "| map | cells | inflation (ms) | A* median (ms) | A* p95 (ms) | cells expanded (median) | "
      "plans |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  struct Case {
    const char* name;
    OccupancyGrid grid;
    int plans;
  };
  std::vector<Case> cases;
  cases.push_back({"PEIS-Home (9 x 6 m)", homeMap(), 200});
  cases.push_back({"2,000 x 2,000 (100 x 100 m)", bigMap(), 20});
  for (auto& c : cases) {
    const auto t0 = Clock::now();
    const Costmap costmap(c.grid, InflationOptions{});
    const double inflation = ms(Clock::now() - t0);
    std::mt19937 rng(11);
    const auto& info = c.grid.info();
    std::uniform_real_distribution<double> ux(info.originX,
                                              info.originX + info.width * info.resolution),
        uy(info.originY, info.originY + info.height * info.resolution);
    std::vector<double> times, expanded;
    int failures = 0;
    while (static_cast<int>(times.size()) < c.plans) {
      const Point2 a{ux(rng), uy(rng)}, b{ux(rng), uy(rng)};
      if (costmap.lethal(c.grid.cellOf(a)) || costmap.lethal(c.grid.cellOf(b))) continue;
      // Far apart: the hard case (across the map).
      if (distance(a, b) < 0.5 * info.width * info.resolution) continue;
      const auto t = Clock::now();
      const auto path = planPath(costmap, a, b);
      times.push_back(ms(Clock::now() - t));
      expanded.push_back(static_cast<double>(path.expanded));
      if (!path.found()) ++failures;
    }
    std::printf("| %s | %d | %.1f | %.2f | %.2f | %.0f | %d (%d without a path) |\n", c.name,
                info.width * info.height, inflation, percentile(times, 0.5),
                percentile(times, 0.95), percentile(expanded, 0.5), c.plans, failures);
  }
}

// A differential-drive robot with the home's odometry noise (trans 0.02,
// rot 0.02, drift 0.01 per metre, as peis-home.yaml's defaults).
struct Robot {
  Pose2 truth, odometry;
  double v = 0, w = 0;
  std::mt19937 rng;
  void step(VelocityCommand c, double dt) {
    v += std::clamp(c.v - v, -dt, dt);
    w += std::clamp(c.w - w, -3 * dt, 3 * dt);
    const double ds = v * dt, dth = w * dt;
    truth = compose(truth, {ds * std::cos(dth / 2), ds * std::sin(dth / 2), dth});
    std::normal_distribution<double> n(0, 1);
    const double ods = ds + 0.02 * std::abs(ds) * n(rng);
    const double odth = dth + 0.02 * std::abs(dth) * n(rng) + 0.01 * std::abs(ds) * n(rng);
    odometry = compose(odometry, {ods * std::cos(odth / 2), ods * std::sin(odth / 2), odth});
  }
};

void accuracyTable() {
  const OccupancyGrid home = homeMap();
  // Each trip starts where the one before ended (so they chain).
  const std::vector<std::pair<Pose2, Point2>> trips{
      {{3.5, 3.0, M_PI}, {6.6, 4.9}}, {{6.6, 4.9, 0}, {2.6, 1.55}}, {{2.6, 1.55, 0}, {6.0, 0.6}},
      {{6.0, 0.6, 0}, {1.2, 4.8}},    {{1.2, 4.8, 0}, {0.8, 2.8}},  {{0.8, 2.8, 0}, {6.6, 4.9}}};
  std::printf(
      "| localization | trips | final error median (cm) | p95 (cm) | max (cm) | mean time (s) |\n");
  std::printf("|---|---|---|---|---|---|\n");
  // One trip per row entry: a fresh robot each time (short trips), or the six
  // trips one after another with the same robot and odometry (drift adds up).
  for (const bool chained : {false, true})
    for (const bool fixes : {true, false}) {
      std::vector<double> errors, durations;
      for (int run = 0; run < 10; ++run) {
        Robot robot{trips[0].first, trips[0].first, 0, 0, std::mt19937(run * 31 + 7)};
        std::mt19937 noise(run);
        std::normal_distribution<double> fixNoise(0, 0.02);  // the tracker's measured error, 2 cm
        Navigator navigator(NavigatorOptions{}, {});
        navigator.setMap(home);
        double t = 1000;
        for (std::size_t trip = 0; trip < trips.size(); ++trip) {
          const auto& [start, goal] = trips[trip];
          if (!chained) {
            robot = Robot{start, start, 0, 0, std::mt19937(run * 31 + 7 + trip)};
            navigator = Navigator(NavigatorOptions{}, {});
            navigator.setMap(home);
          }
          VelocityCommand command;
          auto take = [&](const NavOutput& out) {
            if (out.command) command = *out.command;
          };
          take(navigator.onOdometry(robot.odometry, t));
          char x[32], y[32];
          std::snprintf(x, sizeof x, "%.3f", goal.x);
          std::snprintf(y, sizeof y, "%.3f", goal.y);
          take(navigator.onGoal({"GoTo", {x, y}}, trip + 1));
          int steps = 0;
          for (; steps < 20 * 300 && navigator.state() != NavState::Idle; ++steps) {
            robot.step(command, 0.05);
            t += 0.05;
            // 10 Hz fixes, 100 ms old when they arrive.
            if (fixes && steps % 2 == 0)
              navigator.onFix({robot.truth.x + fixNoise(noise), robot.truth.y + fixNoise(noise)},
                              t - 0.1);
            take(navigator.onOdometry(robot.odometry, t));
          }
          errors.push_back(100 * distance(robot.truth.position(), goal));
          durations.push_back(steps * 0.05);
        }
      }
      double mean = 0;
      for (double d : durations) mean += d / durations.size();
      std::printf("| %s, %s | %zu | %.1f | %.1f | %.1f | %.1f |\n",
                  fixes ? "fixes (10 Hz, σ 2 cm, 100 ms late) + odometry" : "odometry only",
                  chained ? "six trips in a row (drift adds up)" : "one trip from a known start",
                  errors.size(), percentile(errors, 0.5), percentile(errors, 0.95),
                  percentile(errors, 1.0), mean);
    }
}

}  // namespace

int main() {
  std::printf(
      "#### Planning (A* on the inflated grid, robot radius 0.2 m; start and goal at least half "
      "the map apart)\n\n");
  planningTable();
  std::printf(
      "\n#### Final position error at the goal (navigation core in closed loop with a simulated "
      "robot)\n\n");
  accuracyTable();
  return 0;
}
