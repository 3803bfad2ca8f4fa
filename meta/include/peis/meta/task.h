// The task planner: STRIPS-like actions with parameters, preconditions,
// effects and costs, read from YAML (a domain and a problem), searched
// optimally (A* with the admissible LM-cut heuristic). An action can declare
// the configuration goals it needs while it runs (GoTo needs
// `position(?robot)`); the plan carries them, grounded, for the plan executor
// to post to the configurator. Pure: no I/O but fromFile. Format and
// semantics: docs/configuration.md, "Task planning".
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "peis/descriptor.h"

namespace peis::meta::task {

struct Literal {
  Term atom;
  bool negated = false;  // `not at(?r, ?from)`
  std::string toString() const;
  bool operator==(const Literal&) const = default;
};

// What a failure of an action tells: when it fails with a cause containing
// `cause`, these effects hold in the state replanned from (the photo came out
// too dark: `not lit(?place)`). The planner itself never uses them.
struct FailureEffect {
  std::string cause;
  std::vector<Literal> effects;
  bool operator==(const FailureEffect&) const = default;
};

struct Action {
  std::string name;  // `GoTo`
  // Parameters in order, with their types: {"?robot", "robot"}. A type is a
  // unary predicate the problem's objects define (`robot(pippi)`); "" = any.
  std::vector<std::pair<std::string, std::string>> parameters;
  std::vector<Literal> preconditions;
  std::vector<Literal> effects;  // positive: added; negated: deleted
  double cost = 1.0;
  // Configuration goals needed while the action runs, in the goal syntax of
  // Goals::fromArguments, with parameters: `position(?robot)@?robot.mi-position`.
  std::vector<std::string> needs;
  std::vector<FailureEffect> failures;  // `on-failure:` in the domain file
  bool operator==(const Action&) const = default;
};

struct Domain {
  std::string name;
  std::vector<Action> actions;
  // Throws Error(InvalidConfig) "<origin>:<line>: <problem>".
  static Domain fromYaml(std::string_view text, std::string_view origin = "<domain>");
  static Domain fromFile(const std::string& path);
};

struct Problem {
  std::string name;
  std::string domain;  // must equal Domain::name
  // Objects and their types (`pippi: robot`); each adds the fact `robot(pippi)`.
  std::vector<std::pair<std::string, std::string>> objects;
  std::vector<Term> init;     // ground facts true at the start
  std::vector<Literal> goal;  // ground literals to reach
  static Problem fromYaml(std::string_view text, std::string_view origin = "<problem>");
  static Problem fromFile(const std::string& path);
};

struct Step {
  std::string action;
  std::vector<std::string> arguments;
  double cost = 0;
  std::vector<std::string> needs;  // the action's configuration goals, grounded
  std::string toString() const;    // `GoTo(pippi, bed)`
};

struct TaskPlanOptions {
  std::chrono::microseconds timeLimit{0};  // 0: none
  std::int64_t stateLimit = 0;             // 0: none
};

struct TaskPlan {
  bool found = false;
  bool optimal = false;  // found by A* to completion (not cut by a limit)
  std::vector<Step> steps;
  double cost = 0;
  std::int64_t statesExpanded = 0;
  std::int64_t statesGenerated = 0;
  std::int64_t groundActions = 0;
  double milliseconds = 0;
  std::string reason;  // when !found: "no plan: the goal is unreachable", or the limit hit
};

// Throws Error(InvalidConfig) when the problem does not fit the domain (an
// unknown predicate arity, a different domain name, an undeclared object).
TaskPlan planTask(const Domain& domain, const Problem& problem,
                  const TaskPlanOptions& options = {});

std::string formatText(const TaskPlan& plan);
std::string formatJson(const TaskPlan& plan);

}  // namespace peis::meta::task
