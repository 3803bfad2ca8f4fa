// From a scenario to the processes that run it: each PEIS's argv and
// environment, with the placeholders of options, env and goal values
// replaced ({here}, {dir}, {radio}, {radio-port}, {speed}, {ecology},
// {world}), and what the runner waits for to know it joined. A tiny node on
// the emulated ATmega128 becomes two processes: the emulator (its UART on a
// UNIX socket) and a gateway tinybridge on that socket, as the paper's
// PMote reaches the ecology through its XBee link. Pure, given where the
// programs are.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "scenario.h"

namespace peis::scenario {

class ProgramFinder;

struct RunContext {
  std::string dir;      // the run's directory (logs, sockets, sensor files)
  std::string ecology;  // the run's ecology name
  int radioPort = 47100;
  double speed = 1;
};

enum class LaunchRole { World, Peis, TinyHost, Emulator, Gateway };

struct Launch {
  std::string peis;   // the scenario PEIS it stands for (what faults name)
  std::string label;  // its name on the timeline (`blind`, `blind-gateway`)
  LaunchRole role = LaunchRole::Peis;
  std::vector<std::string> argv;
  std::vector<std::pair<std::string, std::string>> env;
  // How the runner knows it joined: these PEIS names are reachable, or the
  // PEIS of this id is (a tiny node's proxy). The emulator joins through its gateway.
  std::vector<std::string> joinNames;
  std::optional<long long> joinId;
  std::string radioControl;  // the file that cuts its radio while it exists (tiny/medium)
  std::string program;       // for messages: the program named in the scenario
};

struct LaunchPlan {
  std::vector<Launch> launches;  // in start order: world, then the scenario's order
  std::vector<std::string> errors;
};

// Replaces the placeholders of `text`; an unknown one is reported through
// `error` (and left as it is).
std::string substitute(const std::string& text, const Scenario& scenario, const RunContext& context,
                       const std::function<void(const std::string&)>& error);

// The directory of the scenario file ({here}).
std::string scenarioDirectory(const Scenario& scenario);

// Plans the processes; programs that cannot be found and placeholders that
// do not exist are errors naming file:line. `without`: PEIS left out.
LaunchPlan planLaunches(const Scenario& scenario, const RunContext& context,
                        const ProgramFinder& finder, const std::vector<std::string>& without = {});

// How a tiny node runs after `on: auto` is decided: Host or Avr.
TinyTarget resolveTarget(const PeisSpec& peis, const ProgramFinder& finder);

}  // namespace peis::scenario
