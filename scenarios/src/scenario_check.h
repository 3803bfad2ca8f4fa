// Validating a parsed scenario without running it (`peis-scenario check`):
// unknown programs and placeholders (through the launch plan), duplicate
// names and ids, goals, faults, narration and conditions that name PEIS the
// scenario does not have, faults a PEIS cannot take (a cut of a PEIS that is
// not on the radio, a freeze of one that is not a simulated sensor),
// conditions without a deadline, `after` chains that name no condition or
// go round, regular expressions that do not compile. Every problem is one
// "file:line: problem" line.
#pragma once

#include <string>
#include <vector>

#include "scenario.h"

namespace peis::scenario {

class ProgramFinder;

// The programs whose PEIS take `fault.freeze` (simulated sensors).
const std::vector<std::string>& freezablePrograms();

std::vector<std::string> checkScenario(const Scenario& scenario, const ProgramFinder& finder,
                                       const std::vector<std::string>& without = {});

// Checks faults given on the command line (`--inject`) against the scenario.
std::vector<std::string> checkFaults(const Scenario& scenario, const std::vector<Fault>& faults,
                                     const ProgramFinder& finder,
                                     const std::vector<std::string>& without = {});

}  // namespace peis::scenario
