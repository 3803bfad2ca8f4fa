// Explanations for goals that cannot be met: which producer is missing and
// why each candidate cannot serve (dead PEIS, failed, avoided, a false
// precondition, an input nobody can produce). Internal to the planner.
#pragma once

#include <string>
#include <vector>

#include "planner/grounding.h"

namespace peis::meta::detail {

// `reachable` is pruneUnreachable's answer; one finding per line.
std::vector<std::string> explainGoal(const ModelIndex& index, const GroundProblem& problem,
                                     const std::vector<char>& reachable, int goalSlot);

}  // namespace peis::meta::detail
