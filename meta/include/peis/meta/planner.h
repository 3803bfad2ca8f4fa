// The configuration planner: model + goals -> the cheapest configuration.
// Pure (no I/O, no kernel), deterministic (ties broken by names), anytime (a
// valid configuration first, then the optimum, with a proven lower bound at
// the deadline). How it searches, and why so: docs/configuration.md.
//
//   peis::meta::ConfigurationPlanner planner(model);       // indexes the model once
//   auto result = planner.plan(goals, {.timeLimit = 100ms});
//   if (result.ok()) for (auto& link : result.configuration.links) ...
//   else for (auto& line : result.explanation) ...
//
// Replanning after a failure (the execution monitor):
//   planner.setFailed(selector, true);                     // or a new Model
//   auto repaired = planner.plan(goals, {.warmStart = &result.configuration});
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>

#include "peis/meta/configuration.h"
#include "peis/meta/goals.h"
#include "peis/meta/model.h"

namespace peis::meta {

struct PlanOptions {
  // Stop searching after this long (measured from the call) and return the
  // best configuration found with its lower bound. Zero: no limit.
  std::chrono::microseconds timeLimit{0};
  // An absolute deadline (steady clock); the earlier of the two applies.
  std::optional<std::chrono::steady_clock::time_point> deadline;
  // Stop after this many search nodes (0: no limit); deterministic, for tests.
  std::int64_t nodeLimit = 0;
  // Return the first valid configuration without improving it.
  bool firstSolutionOnly = false;
  // A configuration deployed before (for instance, before a failure): what of
  // it is still valid seeds the search, so a repair finds a good answer fast.
  const Configuration* warmStart = nullptr;
};

class ConfigurationPlanner {
 public:
  explicit ConfigurationPlanner(Model model);
  ~ConfigurationPlanner();
  ConfigurationPlanner(ConfigurationPlanner&&) noexcept;
  ConfigurationPlanner& operator=(ConfigurationPlanner&&) noexcept;

  const Model& model() const;

  // Marks instances failed (never planned) or recovered. Cheaper than a new
  // planner: the model index is kept.
  void setFailed(const InstanceSelector& selector, bool failed);
  // Marks a PEIS alive or dead.
  void setAlive(std::string_view peis, bool alive);

  // Plans. Throws Error(InvalidArgument) for goals that name an unknown PEIS,
  // component, functionality or information type (the message names it);
  // a goal that cannot be met is not an error but status Infeasible with an
  // explanation.
  PlanResult plan(const Goals& goals, const PlanOptions& options = {}) const;

 private:
  struct Index;
  std::unique_ptr<Index> index_;
};

// The configuration of a result in a few lines a person reads (the
// `peis config plan` output), and the same as JSON.
std::string formatText(const PlanResult& result);
std::string formatJson(const PlanResult& result);

}  // namespace peis::meta
