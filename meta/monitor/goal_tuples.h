// The configurator's goal tuples, as pure text functions.
//
// Any PEIS posts goals by writing a tuple `config.goal.<label>` (in its own
// namespace, or in the configurator's with a remote write): one goal per
// line in the command-line syntax (`position(pippi)@Pippi.mi-position`,
// `run:vac/cleaner/clean`, `avoid:cam2`, `prefer:…`); blank lines and lines
// starting with `#` are skipped. Emptying or erasing the tuple withdraws them.
// The plan executor posts a step's needs this way
// (components/executor/configurator_link.h).
//
// The configurator answers in its own tuple `config.goal-status`: one line
// per goal tuple, `<owner id>.<key> <seqno> <state>[: <reason>]`, state
// `deployed`, `pending` (cannot be planned yet: an unknown PEIS or type),
// `infeasible` (no configuration: the first line of the explanation) or
// `refused` (a line that is not a goal). docs/configuration.md, "Goal tuples".
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/meta/goals.h"

namespace peis::meta {

inline constexpr std::string_view kGoalPrefix = "config.goal.";
inline constexpr std::string_view kGoalStatusKey = "config.goal-status";

// The goals of one tuple. `origin` names it (`Pippi.config.goal.planner`);
// each goal's origin becomes `<origin>:<line>`. A line that is not a goal
// is left out and reported in `problems` as `<origin>:<line>: <problem>`.
struct ParsedGoalTuple {
  Goals goals;
  std::vector<std::string> problems;
};
ParsedGoalTuple parseGoalTuple(std::string_view text, const std::string& origin);

// One goal per line, each ended by a newline (what the executor writes).
std::string formatGoalTuple(const std::vector<std::string>& goals);

// Adds `more` to `goals` (information, run goals and constraints).
void mergeGoals(Goals& goals, const Goals& more);

enum class GoalState { Deployed, Pending, Infeasible, Refused };
const char* toString(GoalState state);

struct GoalStatusLine {
  int owner = 0;
  std::string key;          // `config.goal.<label>`
  std::uint64_t seqno = 0;  // of the goal tuple this answers
  GoalState state = GoalState::Pending;
  std::string reason;
  std::string format() const;  // `12.config.goal.planner 3 deployed`
  static std::optional<GoalStatusLine> parse(std::string_view line);
  bool operator==(const GoalStatusLine&) const = default;
};
std::string formatGoalStatus(const std::vector<GoalStatusLine>& lines);
std::vector<GoalStatusLine> parseGoalStatus(std::string_view text);

}  // namespace peis::meta
