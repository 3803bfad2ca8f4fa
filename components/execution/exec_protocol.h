// The delegation protocol of javaspace-peis-middleware.txt §5: a planner
// hands an action to the component that executes it by writing that
// component's `ExecGoal` tuple, and the component reports with its own
// `ExecStatus` tuple. Shared by navigation, the talk output, the vacuum
// cleaner and the plan executor (docs/components/execution.md).
//
//   ExecGoal   = ACTION                         GoTo(bed)  GoTo(1.5, 2.0)  Talk(wakeup)  Stop
//   ExecStatus = STATE GOAL-ID ACTION [CAUSE]   running 4 GoTo(bed)
//                                               failed 5 GoTo(attic) unknown place 'attic'
//
// GOAL-ID is the seqno the executing PEIS gave the ExecGoal write (the
// writer gets it back from Kernel::set), so a watcher tells the status of
// its own goal from that of an earlier or later one.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace peis::exec {

inline constexpr std::string_view kExecGoal = "ExecGoal";
inline constexpr std::string_view kExecStatus = "ExecStatus";
inline constexpr std::size_t kMaxActionBytes = 200;

// `Name(arg, arg)`, or `Name` alone. Names and arguments are non-empty and
// contain no spaces, parentheses or commas (numbers, place names, words).
struct Action {
  std::string name;
  std::vector<std::string> args;
  std::string toString() const;  // canonical: `GoTo(1.5,2)` -> "GoTo(1.5, 2)"
  bool operator==(const Action&) const = default;
};

// Parses an action; on failure returns nothing and says why in `problem`.
std::optional<Action> parseAction(std::string_view text, std::string* problem = nullptr);

enum class ExecState { Running, Success, Failed };
const char* toString(ExecState state);

struct ExecStatus {
  ExecState state = ExecState::Running;
  std::uint64_t goalId = 0;
  std::string action;  // canonical text of the action
  std::string cause;   // why it failed (free text), empty otherwise
  std::string toString() const;
  bool operator==(const ExecStatus&) const = default;
};

std::optional<ExecStatus> parseExecStatus(std::string_view text, std::string* problem = nullptr);

// A number argument (`1.5`, `-2`); nothing unless the whole text is a finite number.
std::optional<double> parseNumber(std::string_view text);

}  // namespace peis::exec
