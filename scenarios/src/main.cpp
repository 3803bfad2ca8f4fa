// peis-scenario: runs a reference home scenario from its file, or checks the
// file without running it (docs/scenarios.md). `peis scenario ...` runs it
// as git runs its subcommands.
#include <peis/log.h>
#include <signal.h>

#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "program_finder.h"
#include "runner.h"
#include "scenario_check.h"
#include "scenario_yaml.h"
#include "timeline.h"

namespace {

using namespace peis::scenario;

const char* kUsage = R"(Usage: peis-scenario run FILE [options]
       peis-scenario check FILE [--without PEIS]... [--inject FAULT]...

run    starts every PEIS of the scenario FILE as its own process (loopback, the
       real network stack), prints the timeline, writes the goals and injects
       the faults at their scenario times, records every tuple change in a
       SQLite trace, saves the world's picture of the run, stops everything it
       started, and exits 0 when every success condition held.
check  validates FILE without running it: file:line errors, unknown programs,
       names of PEIS the scenario does not have.

Options of run:
  --speed X         simulated seconds per real second, 0.1..100 (default: the
                    file's speed:)
  --inject FAULT    one more fault: 'KIND PEIS at SECONDS [for SECONDS]', KIND
                    kill, stop, cut or freeze (repeatable), e.g.
                    --inject 'stop camera-living-1 at 5 for 8'
  --trace FILE      the trace (default NAME.trace.sqlite; '' for none)
  --picture FILE    the world's picture of the run (default NAME.png; '' for none)
  --without PEIS    leave that PEIS out (repeatable)
  --workdir DIR     logs, sockets and sensor files there (default: a new
                    temporary directory, removed after a successful run)
  --keep            keep the work directory
  --ecology NAME    the ecology (default scenario-NAME-PID)
  --until S         end at scenario time S at the latest: a condition that has
                    not held by then fails (a shorter run than the deadlines)
  --help            this text

Exit status of run: 0 every success condition held; 1 one did not hold by its
deadline (named); 2 bad usage or an invalid scenario; 3 a PEIS did not start or
join; 130 / 143 interrupted by SIGINT / SIGTERM (everything stopped, the trace
kept). Of check: 0 valid, 1 invalid, 2 bad usage.
Programs are found in PEIS_EXEC_PATH, the build tree, beside peis-scenario,
<prefix>/libexec/peis and PATH.
)";

int usage(const std::string& why) {
  std::cerr << "peis-scenario: " << why << " (see --help)\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  // SIGINT and SIGTERM are taken by the runner's loop (sigtimedwait): block
  // them before any thread starts, so every thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  // Scenarios stay on this host unless told otherwise.
  ::setenv("PEIS_DISCOVERY_SCOPE", "loopback", 0);
  // The runner's own PEIS keeps to warnings (the timeline says what
  // happens); the PEIS it starts log as usual into their log files.
  if (!peis::log::levelFromEnvironment()) peis::log::setLevel(peis::log::Level::Warn);

  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) return usage("which command: run or check?");
  if (args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    std::cout << kUsage;
    return 0;
  }
  const std::string command = args[0];
  if (command != "run" && command != "check")
    return usage("unknown command '" + command + "': run or check");
  std::string file;
  RunOptions options;
  std::vector<std::string> injected;
  bool traceGiven = false, pictureGiven = false;
  for (std::size_t i = 1; i < args.size(); ++i) {
    const std::string& a = args[i];
    const bool hasValue = i + 1 < args.size();
    auto value = [&]() -> const std::string& { return args[++i]; };
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    } else if (a == "--without" && hasValue) {
      options.without.push_back(value());
    } else if (a == "--inject" && hasValue) {
      injected.push_back(value());
    } else if (command == "check" && a.rfind("--", 0) == 0) {
      return usage("check does not take " + a);
    } else if (a == "--speed" && hasValue) {
      const std::string& v = value();
      char* end = nullptr;
      const double speed = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !(speed >= 0.1 && speed <= 100))
        return usage("--speed takes 0.1..100, not '" + v + "'");
      options.speed = speed;
    } else if (a == "--trace" && hasValue) {
      options.tracePath = value();
      traceGiven = true;
    } else if (a == "--picture" && hasValue) {
      options.picturePath = value();
      pictureGiven = true;
    } else if (a == "--workdir" && hasValue) {
      options.workDir = value();
    } else if (a == "--ecology" && hasValue) {
      options.ecology = value();
    } else if (a == "--until" && hasValue) {
      const std::string& v = value();
      char* end = nullptr;
      const double until = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !(until >= 0 && until <= 1e7))
        return usage("--until takes scenario seconds, not '" + v + "'");
      options.until = until;
    } else if (a == "--keep") {
      options.keepWorkDir = true;
    } else if (a.rfind("--", 0) == 0) {
      return usage(hasValue || a == "--keep" ? "unknown option " + a
                                             : a + " needs a value or is unknown");
    } else if (file.empty()) {
      file = a;
    } else {
      return usage("one scenario file only ('" + file + "' and '" + a + "')");
    }
  }
  if (file.empty()) return usage(command + " needs a scenario FILE");

  Scenario scenario;
  std::vector<std::string> errors;
  try {
    scenario = loadScenario(file);
    for (const auto& text : injected) options.injected.push_back(parseInjectedFault(text));
  } catch (const ScenarioError& e) {
    errors.push_back(e.what());
  }
  const ProgramFinder finder = ProgramFinder::forThisProcess();
  if (errors.empty()) {
    errors = checkScenario(scenario, finder, options.without);
    const auto faultErrors = checkFaults(scenario, options.injected, finder, options.without);
    errors.insert(errors.end(), faultErrors.begin(), faultErrors.end());
  }
  if (!errors.empty()) {
    for (const auto& e : errors) std::cerr << e << "\n";
    std::cerr << "peis-scenario: " << file << ": " << errors.size()
              << (errors.size() == 1 ? " problem" : " problems") << "\n";
    return command == "check" ? 1 : kBadScenario;
  }
  if (command == "check") {
    auto count = [](std::size_t n, const std::string& what) {
      return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
    };
    std::cout << file << ": valid (" << scenario.peis.size() + (scenario.world ? 1 : 0) << " PEIS, "
              << count(scenario.goals.size(), "goal") << ", "
              << count(scenario.faults.size(), "fault") << ", "
              << count(scenario.success.size(), "success condition") << ")\n";
    return 0;
  }
  if (!traceGiven) options.tracePath = scenario.name + ".trace.sqlite";
  if (!pictureGiven) options.picturePath = scenario.name + ".png";
  if (!scenario.description.empty()) std::cout << scenario.description << "\n\n";
  Timeline timeline;
  return runScenario(scenario, options, finder, timeline);
}
