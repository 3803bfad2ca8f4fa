// Reading a scenario file (docs/scenarios.md): YAML into the Scenario model,
// every problem a ScenarioError "file:line: problem" — broken YAML, unknown
// keys (with the known ones), wrong types, missing fields, a fault or test
// that names two kinds at once. Pure: no lookups of programs or PEIS
// (scenario_check.h does those).
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

#include "scenario.h"

namespace peis::scenario {

class ScenarioError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses `text`; `path` names it in errors and is kept in Scenario::path.
Scenario parseScenario(std::string_view text, const std::string& path);
// Reads and parses a file (a file that cannot be read is a ScenarioError).
Scenario loadScenario(const std::string& path);

// "OWNER.KEY" split at its first dot; nullopt when either part is empty.
std::optional<std::pair<std::string, std::string>> splitTupleName(std::string_view text);

// Parses one `--inject` fault: "KIND PEIS at T [for S]" (KIND kill, stop,
// cut, freeze); throws ScenarioError saying what is wrong.
Fault parseInjectedFault(std::string_view text);

}  // namespace peis::scenario
