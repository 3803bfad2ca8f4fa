// peis-plan: the task planner on the command line (`peis plan …`): reads a
// domain and a problem (YAML), prints an optimal plan and its cost, or says
// there is none with the number of states searched.
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "peis/error.h"
#include "peis/meta/task.h"

namespace {

void help() {
  std::cout << R"(Usage: peis-plan DOMAIN PROBLEM [--json] [--time-limit MS]   (also: peis plan …)

Plans optimally (A* with the LM-cut heuristic) from a task domain and problem
in YAML (docs/configuration.md, "Task planning"); prints the plan, its cost and
the configuration goals each step needs while it runs.
Exit status: 0 a plan, 1 no plan, 2 bad arguments or input.
)";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  bool json = false;
  long timeLimitMs = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      help();
      return 0;
    } else if (a == "--json") {
      json = true;
    } else if (a == "--time-limit" && i + 1 < argc) {
      char* end = nullptr;
      timeLimitMs = std::strtol(argv[++i], &end, 10);
      if (*end || timeLimitMs < 0) {
        std::cerr << "peis-plan: --time-limit takes milliseconds\n";
        return 2;
      }
    } else if (a.rfind("--", 0) == 0) {
      std::cerr << "peis-plan: unknown option " << a << " (see peis-plan --help)\n";
      return 2;
    } else {
      files.push_back(a);
    }
  }
  if (files.size() != 2) {
    std::cerr << "peis-plan: give DOMAIN and PROBLEM (see peis-plan --help)\n";
    return 2;
  }
  try {
    const auto domain = peis::meta::task::Domain::fromFile(files[0]);
    const auto problem = peis::meta::task::Problem::fromFile(files[1]);
    peis::meta::task::TaskPlanOptions options;
    options.timeLimit = std::chrono::milliseconds(timeLimitMs);
    const auto plan = peis::meta::task::planTask(domain, problem, options);
    std::cout << (json ? peis::meta::task::formatJson(plan) + "\n"
                       : peis::meta::task::formatText(plan));
    return plan.found ? 0 : 1;
  } catch (const peis::Error& e) {
    std::cerr << "peis-plan: " << e.what() << "\n";
    return 2;
  }
}
