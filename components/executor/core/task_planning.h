// The executor's side of task planning (javaspace-peis-middleware.txt §5:
// "Emil receives the high-level goal to wake up Johanna … and generates a
// plan … using PTLplan"): a task (goal literals) is planned with the
// meta-level's task planner on the executor's domain and problem, and a
// failure is replanned from the current state — the problem's initial state
// with the effects of every step done so far. Pure: no network.
#pragma once

#include <peis/meta/task.h>

#include <string>
#include <string_view>
#include <vector>

#include "plan_runner.h"

namespace peis::executor {

// Parses a task: goal literals separated by commas (outside parentheses),
// each `atom` or `not atom`: "awake(johanna), at(pippi, sofa)". Throws
// std::invalid_argument naming the bad literal.
std::vector<meta::task::Literal> parseTask(std::string_view text);

// The state after `done` was executed from `problem`'s initial state: each
// step's action is looked up in `domain`, its parameters bound to the step's
// arguments and its other variables to facts of the state (its positive
// preconditions), then its effects applied. Throws std::invalid_argument when
// a step does not fit the domain or cannot be applied in the state.
//
// `failures` are the steps that failed on the way, each with its cause and
// how many of `done` came before it: the effects its action declares for
// that cause (`on-failure:`, matched by containment: "too dark" in "… failed
// on astrid-camera: too dark (…)") are applied there — what each failure
// taught about the state, kept across every replan of the task.
struct FailedStep {
  PlanStep step;
  std::string cause;
  std::size_t after = 0;  // the number of done steps before it
};
std::vector<Term> stateAfter(const meta::task::Domain& domain, const meta::task::Problem& problem,
                             const std::vector<PlanStep>& done,
                             const std::vector<FailedStep>& failures = {});

struct PlannedTask {
  bool found = false;
  std::vector<PlanStep> steps;
  std::string text;  // the plan (`GoTo(pippi, bed); Talk(pippi, wakeup)`) or why there is none
};

// Plans `goal` from the state after `done`.
PlannedTask planFrom(const meta::task::Domain& domain, const meta::task::Problem& problem,
                     const std::vector<meta::task::Literal>& goal,
                     const std::vector<PlanStep>& done = {},
                     const std::vector<FailedStep>& failures = {});

}  // namespace peis::executor
