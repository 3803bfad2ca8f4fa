// peis-bench-planner: the configuration planner and the task planner on
// random models (docs/performance.md, "Planning"). Prints markdown tables.
//   sensing / layered families at 10, 100, 1,000, 10,000 functionalities:
//   time to the first valid configuration, to the proven optimum (p50, p95),
//   the share proven optimal within the time limit, the greedy dive's excess
//   over the optimum; replanning after one functionality fails; the task
//   planner on the home problems and a generated 20-room, 5-robot domain.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "peis/meta/planner.h"
#include "peis/meta/task.h"
#include "random_models.h"

using namespace peis::meta;
using Clock = std::chrono::steady_clock;

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5))];
}

double ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

void configurationTable(long timeLimitMs) {
  std::printf(
      "| family | functionalities | runs | relevant | first valid p50 / max (ms) | plan p50 (ms) | "
      "plan p95 (ms) | proven optimal (or infeasible) | greedy excess (mean / max) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const char* family : {"sensing", "layered"}) {
    for (int size : {10, 100, 1000, 10000}) {
      const int runs = size >= 10000 ? 10 : size >= 1000 ? 30 : 50;
      std::mt19937 rng(1000 + size);
      std::vector<double> first, full, excess;
      double relevant = 0;
      int optimal = 0;
      for (int r = 0; r < runs; ++r) {
        auto p = std::strcmp(family, "sensing") == 0 ? testing::sensing(rng, size)
                                                     : testing::layered(rng, size);
        ConfigurationPlanner planner(p.model);
        PlanOptions quick;
        quick.firstSolutionOnly = true;
        auto t0 = Clock::now();
        const auto a = planner.plan(p.goals, quick);
        first.push_back(ms(Clock::now() - t0));
        PlanOptions limited;
        limited.timeLimit = std::chrono::milliseconds(timeLimitMs);
        t0 = Clock::now();
        const auto b = planner.plan(p.goals, limited);
        full.push_back(ms(Clock::now() - t0));
        relevant += static_cast<double>(b.stats.relevantInstances);
        if (b.status == PlanStatus::Infeasible) ++optimal;  // proven too
        if (b.status == PlanStatus::Optimal) {
          ++optimal;
          if (a.ok() && b.configuration.cost > 0) {
            excess.push_back(100 * (a.configuration.cost - b.configuration.cost) /
                             b.configuration.cost);
          }
        }
      }
      double mean = 0;
      for (double e : excess) mean += e;
      mean = excess.empty() ? 0 : mean / static_cast<double>(excess.size());
      std::printf(
          "| %s | %d | %d | %.0f | %.3f / %.3f | %.3f | %.3f | %d/%d | %.1f %% / %.1f %% |\n",
          family, size, runs, relevant / runs, percentile(first, 0.5), percentile(first, 1.0),
          percentile(full, 0.5), percentile(full, 0.95), optimal, runs, mean,
          excess.empty() ? 0.0 : *std::max_element(excess.begin(), excess.end()));
      std::fflush(stdout);
    }
  }
}

void replanTable(long timeLimitMs) {
  std::printf(
      "\n| family | functionalities | runs | replan after a failure p50 (ms) | p95 (ms) | proven "
      "optimal |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (const char* family : {"sensing", "layered"}) {
    std::mt19937 rng(77);
    std::vector<double> times;
    int optimal = 0, runs = 0;
    while (runs < 30) {
      auto p = std::strcmp(family, "sensing") == 0 ? testing::sensing(rng, 1000)
                                                   : testing::layered(rng, 1000);
      ConfigurationPlanner planner(p.model);
      PlanOptions limited;
      limited.timeLimit = std::chrono::milliseconds(timeLimitMs);
      const auto before = planner.plan(p.goals, limited);
      if (!before.ok() || before.configuration.instances.empty()) continue;
      // The monitor's call: one active functionality failed; plan again, warm.
      const auto& victim =
          before.configuration.instances[rng() % before.configuration.instances.size()];
      planner.setFailed({victim.peis, victim.component, victim.functionality, {}}, true);
      PlanOptions warm = limited;
      warm.warmStart = &before.configuration;
      const auto t0 = Clock::now();
      const auto after = planner.plan(p.goals, warm);
      times.push_back(ms(Clock::now() - t0));
      optimal += after.status == PlanStatus::Optimal || after.status == PlanStatus::Infeasible;
      ++runs;
    }
    std::printf("| %s | 1000 | %d | %.3f | %.3f | %d/%d |\n", family, runs, percentile(times, 0.5),
                percentile(times, 0.95), optimal, runs);
  }
}

std::string gridDomainProblem(int rooms, int robots, int cleanGoals, std::mt19937& rng) {
  // Rooms in a grid of 4 columns; robots start and must end in random rooms,
  // and `cleanGoals` rooms must be cleaned.
  std::string objects, init, goal;
  const int columns = 4;
  for (int r = 0; r < rooms; ++r) {
    objects += (objects.empty() ? "" : ", ") + std::string("room") + std::to_string(r) + ": place";
    const int right = r + 1, down = r + columns;
    if (r % columns != columns - 1 && right < rooms) {
      init +=
          "  - \"adjacent(room" + std::to_string(r) + ", room" + std::to_string(right) + ")\"\n";
      init +=
          "  - \"adjacent(room" + std::to_string(right) + ", room" + std::to_string(r) + ")\"\n";
    }
    if (down < rooms) {
      init += "  - \"adjacent(room" + std::to_string(r) + ", room" + std::to_string(down) + ")\"\n";
      init += "  - \"adjacent(room" + std::to_string(down) + ", room" + std::to_string(r) + ")\"\n";
    }
  }
  for (int b = 0; b < robots; ++b) {
    objects += ", robot" + std::to_string(b) + ": robot";
    init +=
        "  - \"at(robot" + std::to_string(b) + ", room" + std::to_string(rng() % rooms) + ")\"\n";
    goal +=
        "  - \"at(robot" + std::to_string(b) + ", room" + std::to_string(rng() % rooms) + ")\"\n";
  }
  for (int c = 0; c < cleanGoals; ++c)
    goal += "  - \"clean(room" + std::to_string(rng() % rooms) + ")\"\n";
  return "problem: grid\ndomain: grid\nobjects: {" + objects + "}\ninit:\n" + init + "goal:\n" +
         goal;
}

const char* const kGridDomain = R"yaml(
domain: grid
actions:
  - name: Move
    parameters: {robot: robot, to: place}
    preconditions: ["at(?robot, ?from)", "adjacent(?from, ?to)"]
    effects: ["at(?robot, ?to)", "not at(?robot, ?from)"]
    needs: ["position(?robot)@?robot.mi-position"]
  - name: Clean
    parameters: {robot: robot, room: place}
    preconditions: ["at(?robot, ?room)"]
    effects: ["clean(?room)"]
    cost: 2
)yaml";

void taskTable(const std::string& domains) {
  std::printf(
      "\n| task problem | ground actions | plan length | cost | states expanded | time (ms) |\n");
  std::printf("|---|---|---|---|---|---|\n");
  const auto home = task::Domain::fromFile(domains + "/home.domain.yaml");
  for (const char* name : {"wakeup", "photo", "vacuum"}) {
    const auto problem = task::Problem::fromFile(domains + "/" + name + ".problem.yaml");
    const auto plan = task::planTask(home, problem);
    std::printf("| %s | %lld | %zu | %g | %lld | %.3f |\n", name,
                static_cast<long long>(plan.groundActions), plan.steps.size(), plan.cost,
                static_cast<long long>(plan.statesExpanded), plan.milliseconds);
  }
  const auto grid = task::Domain::fromYaml(kGridDomain, "grid");
  std::mt19937 rng(5);
  std::vector<double> times;
  for (int trial = 0; trial < 5; ++trial) {
    const auto problem =
        task::Problem::fromYaml(gridDomainProblem(20, 5, trial < 3 ? 0 : 1, rng), "grid problem");
    task::TaskPlanOptions options;
    options.timeLimit = std::chrono::seconds(20);
    const auto plan = task::planTask(grid, problem, options);
    std::printf("| 20 rooms, 5 robots #%d | %lld | %zu | %g | %lld | %.3f%s |\n", trial + 1,
                static_cast<long long>(plan.groundActions), plan.steps.size(), plan.cost,
                static_cast<long long>(plan.statesExpanded), plan.milliseconds,
                plan.found ? "" : " (no plan)");
  }
}

}  // namespace

int main(int argc, char** argv) {
  long timeLimitMs = 2000;
  std::string domains = PEIS_DOMAINS_DIR;
  bool onlyTask = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--help")) {
      std::printf(
          "Usage: peis-bench-planner [--time-limit MS] [--domains DIR] [--task-only]\n"
          "Benchmarks the configuration and task planners; prints markdown tables.\n");
      return 0;
    }
    if (!std::strcmp(argv[i], "--time-limit") && i + 1 < argc) timeLimitMs = std::atol(argv[++i]);
    if (!std::strcmp(argv[i], "--domains") && i + 1 < argc) domains = argv[++i];
    if (!std::strcmp(argv[i], "--task-only")) onlyTask = true;
  }
  std::printf(
      "Configuration planner, time limit %ld ms per plan (proven optimal = finished within "
      "it).\n\n",
      timeLimitMs);
  if (!onlyTask) {
    configurationTable(timeLimitMs);
    replanTable(timeLimitMs);
  }
  taskTable(domains);
}
