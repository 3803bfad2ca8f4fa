// Running a scenario (`peis-scenario run`): starts every PEIS as its own
// process in an ecology of the run's own (loopback, the real network stack),
// joins that ecology itself as a tool PEIS to watch it, prints the timeline,
// writes goals and injects faults at their scenario times, judges the
// success conditions, records the trace, asks the world for its picture,
// and stops everything it started by pid — also on SIGINT and SIGTERM,
// which the caller must have blocked in every thread (main.cpp does) so the
// runner takes them with sigtimedwait.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "scenario.h"

namespace peis::scenario {

class ProgramFinder;
class Timeline;

// Exit statuses of `peis-scenario run`.
enum RunStatus : int {
  kSucceeded = 0,        // every success condition held
  kConditionFailed = 1,  // one missed its deadline (named)
  kBadScenario = 2,      // the file or the options are wrong (nothing started)
  kStartFailed = 3,      // a PEIS did not start or join
  kInterrupted = 130,    // SIGINT (143: SIGTERM)
};

struct RunOptions {
  std::optional<double> speed;
  std::vector<Fault> injected;       // --inject
  std::vector<std::string> without;  // --without: PEIS left out
  std::string tracePath;             // empty: no trace
  std::string picturePath;           // empty: no picture
  std::string workDir;               // empty: a fresh temporary directory
  bool keepWorkDir = false;          // else removed after a successful run
  std::string ecology;               // empty: scenario-<name>-<pid>
  std::optional<double> until;       // --until: end at this scenario time at the latest
};

// Runs `scenario` (already checked) and returns a RunStatus.
int runScenario(const Scenario& scenario, const RunOptions& options, const ProgramFinder& finder,
                Timeline& timeline);

}  // namespace peis::scenario
