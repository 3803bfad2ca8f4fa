// An independent, deliberately naive configuration planner for tests and
// benchmarks: grounds every functionality over every constant of the model,
// then tries every set of active instances and every assignment of producers
// (exhaustive), or hands the same ground problem to GLPK as a MILP. Also a
// validator that checks a configuration against the model from scratch.
// Shares no code with meta/planner.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "peis/meta/configuration.h"
#include "peis/meta/goals.h"
#include "peis/meta/model.h"

namespace peis::meta::reference {

struct GroundInstance {
  std::string name;  // peis/component/functionality{bindings}
  int peis = 0;
  double cost = 0;
  std::vector<std::pair<std::string, std::string>> inputs;   // (meta key, term)
  std::vector<std::pair<std::string, std::string>> outputs;  // (key, term)
};

struct Ground {
  std::vector<GroundInstance> instances;
  struct Need {
    int peis = -1;  // consumer PEIS, -1: none
    std::string key, term;
  };
  std::vector<Need> goals;
};

// Naive grounding of the live, unfailed, unavoided functionalities. Returns
// nothing when there would be more than `maxInstances`.
std::optional<Ground> groundNaively(const Model& model, const Goals& goals,
                                    std::size_t maxInstances = 1000);

// The cheapest cost (nothing: no configuration), by trying everything.
std::optional<double> exhaustiveCost(const Model& model, const Ground& ground);

// The same with GLPK's MILP solver (branch and cut); nothing: infeasible.
std::optional<double> milpCost(const Model& model, const Ground& ground);

// Empty when `config` is a valid configuration for the goals whose cost is
// the sum of its parts; else what is wrong.
std::string validate(const Model& model, const Goals& goals, const Configuration& config);

}  // namespace peis::meta::reference
