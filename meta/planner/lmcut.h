// The LM-cut heuristic (Helmert & Domshlak 2009) on a delete-free STRIPS
// task: an admissible lower bound on the cost of reaching the goal facts,
// from the facts given as true. Shared by the configuration planner (its
// bound in branch and bound) and the task planner (A*). Pure and reusable:
// one LmCut per task, compute() as often as needed with changed costs.
#pragma once

#include <limits>
#include <utility>
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

  // After a compute() that returned h below its bound: for each action a,
  // how much more than h any plan that uses a costs at least (every plan
  // pays h on the landmarks found, and its actions' residual costs besides:
  // a's own, a chain that supports a's preconditions, and a chain from a's
  // effect to the goal). kInfinity for actions that cannot be used. The
  // caller may drop actions for which h + this reaches what it can afford.
  void usageCosts(std::vector<double>& out);

  // Fresh h^max each round (the original LM-cut) or h^max updated from the
  // cut only (faster per round; other supporters on ties, weaker bounds).
  bool incrementalHmax = false;

  // h^max alone (cheaper, weaker); kInfinity when unreachable.
  double hmax(const std::vector<double>& costs, const std::vector<char>& isTrue,
              const std::vector<int>& goal);

 private:
  void setGoal(const std::vector<int>& goal);
  void computeHmax(const std::vector<char>& isTrue);
  void updateHmax(const std::vector<int>& cut);
  void push(double value, int fact);
  std::pair<double, int> pop();

  const RelaxedTask& task_;
  int init_ = 0, goalFact_ = 0;            // the artificial facts
  std::vector<std::vector<int>> preOf_;    // fact -> actions having it as precondition
  std::vector<std::vector<int>> addedBy_;  // fact -> actions adding it
  std::vector<std::vector<int>> pre_;      // per action, with init for empty ones
  std::vector<std::vector<int>> add_;
  // Work arrays.
  std::vector<double> cost_, hmax_, supporterCost_, toGoal_;
  std::vector<int> unsatisfied_, pcf_, stack_, cut_;
  std::vector<char> status_;
  std::vector<long> popped_;  // when each fact was last popped (ties of supporters)
  long pops_ = 0;
  std::vector<std::pair<double, int>> queue_;  // a binary heap, smallest first
};

}  // namespace peis::meta
