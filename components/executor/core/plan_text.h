// Plans and static configuration links as text, for the executor's command
// line and its `plan` tuple:
//
//   plan  = STEP ; STEP ; …          GoTo(Pippi, bed) | position(pippi)@Pippi.mi-position ;
//   Talk(Pippi, wakeup) STEP  = ACTION [ | NEED | NEED … ] NEED  = INFORMATION@PEIS.KEY     (the
//   goal syntax of the configurator) link  = INFORMATION=PEIS.KEY
//   position(pippi)=tracker.position.Pippi
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "plan_runner.h"

namespace peis::executor {

// Parses a plan; throws std::invalid_argument naming the bad step.
std::vector<PlanStep> parsePlan(std::string_view text);
std::string formatPlan(const std::vector<PlanStep>& plan);

// A configuration goal `INFORMATION@PEIS.KEY` split into its parts.
struct NeedParts {
  std::string information, consumer, key;
};
std::optional<NeedParts> parseNeed(std::string_view need);

// A producer `PEIS.KEY` for an information (a hand-written configuration).
struct StaticLink {
  std::string information, producer, key;
};
// Parses `INFORMATION=PEIS.KEY`; throws std::invalid_argument.
StaticLink parseStaticLink(std::string_view text);

}  // namespace peis::executor
