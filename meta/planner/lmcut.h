// The LM-cut heuristic (Helmert & Domshlak 2009) on a delete-free STRIPS
// task: an admissible lower bound on the cost of reaching the goal facts,
// from the facts given as true. Shared by the configuration planner (its
// bound in branch and bound) and the task planner (A*). Pure and reusable:
// one LmCut per task, compute() as often as needed with changed costs.
#pragma once

#include <limits>
#include <vector>

namespace peis::meta {

struct RelaxedTask {
  struct Action {
    std::vector<int> pre;  // facts that must be reached first
    std::vector<int> add;  // facts it reaches
  };
  int facts = 0;
  std::vector<Action> actions;
};

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

class LmCut {
 public:
  explicit LmCut(const RelaxedTask& task);

  // `costs[a]`: the cost of action a (kInfinity: the action is unavailable).
  // `isTrue[f]` != 0: fact f holds already (may be empty: none holds).
  // Returns kInfinity when the goal is unreachable. Stops early, returning a
  // value >= `bound`, once the sum reaches `bound`.
  double compute(const std::vector<double>& costs, const std::vector<char>& isTrue,
                 const std::vector<int>& goal, double bound = kInfinity);

  // The same, and appends each cut found (its actions and its cost) to
  // `landmarks`: a cost partitioning that a caller can reuse after actions
  // became free or unavailable (incremental LM-cut).
  struct Landmark {
    std::vector<int> actions;
    double cost = 0;
  };
  double compute(const std::vector<double>& costs, const std::vector<char>& isTrue,
                 const std::vector<int>& goal, double bound, std::vector<Landmark>* landmarks);

  // h^max alone (cheaper, weaker); kInfinity when unreachable.
  double hmax(const std::vector<double>& costs, const std::vector<char>& isTrue,
              const std::vector<int>& goal);

 private:
  void computeHmax(const std::vector<char>& isTrue);

  const RelaxedTask& task_;
  int init_ = 0, goalFact_ = 0;            // the artificial facts
  std::vector<std::vector<int>> preOf_;    // fact -> actions having it as precondition
  std::vector<std::vector<int>> addedBy_;  // fact -> actions adding it
  std::vector<std::vector<int>> pre_;      // per action, with init for empty ones
  std::vector<std::vector<int>> add_;
  // Work arrays.
  std::vector<double> cost_, hmax_;
  std::vector<int> unsatisfied_, pcf_;
  std::vector<char> inZone_, reached_;
};

}  // namespace peis::meta
