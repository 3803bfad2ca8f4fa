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

  // Cuts (disjunctive action landmarks) with their costs, in one flat list:
  // a cost partitioning that a caller can reuse after actions became free or
  // unavailable (incremental LM-cut). Append-only, truncated by the caller.
  struct Landmarks {
    std::vector<int> actions;
    std::vector<int> start{0};  // cut i is actions[start[i] .. start[i + 1])
    std::vector<double> cost;
    int size() const { return static_cast<int>(cost.size()); }
    const int* begin(int i) const { return actions.data() + start[i]; }
    const int* end(int i) const { return actions.data() + start[i + 1]; }
    void truncate(int n);
  };
  // The same, and appends each cut found to `landmarks` and its index to `found`.
  double compute(const std::vector<double>& costs, const std::vector<char>& isTrue,
                 const std::vector<int>& goal, double bound, Landmarks* landmarks,
                 std::vector<int>* found);

  // After a compute() that returned h below its bound: for each action a,
  // how much more than h any plan that uses a costs at least. Every plan
  // pays h on the cuts found and its actions' residual costs besides (an
  // LP-dual argument): a's own, a support of a's preconditions (at least
  // their residual h^max) and a chain from a's effect to the goal (a plan
  // without redundant actions uses the effect). kInfinity for actions that
  // cannot be used. The caller may drop actions for which h + this reaches
  // what it can afford.
  void usageCosts(std::vector<double>& out);

  // After each cut, h^max updated from the cut only (cheaper) instead of
  // afresh (supporters may differ on ties: other, often weaker, bounds).
  bool incremental = false;

  // h^max alone (cheaper, weaker); kInfinity when unreachable.
  double hmax(const std::vector<double>& costs, const std::vector<char>& isTrue,
              const std::vector<int>& goal);

 private:
  struct Entry {
    double value;
    int fact;
    bool operator<(const Entry& o) const {
      return value < o.value || (value == o.value && fact < o.fact);
    }
  };
  void setGoal(const std::vector<int>& goal);
  void computeHmax(const std::vector<char>& isTrue);
  void updateHmax();
  // Calls f(action) for each action with `fact` as a precondition.
  template <typename F>
  void forEachUse(int fact, F&& f) const;
  void push(double value, int fact);
  Entry pop();

  int init_ = 0, goalFact_ = 0, goalAction_ = 0;  // the artificial facts and action
  // Flat lists (compressed rows): preconditions and effects per action,
  // and per fact the actions that need it (the goal action apart) and
  // the actions that add it.
  std::vector<int> preStart_, pre_, addStart_, add_, useStart_, use_, adderStart_, adder_;
  std::vector<int> goal_;     // the goal action's preconditions
  std::vector<char> isGoal_;  // per fact: a precondition of the goal action
  // Work arrays.
  std::vector<double> cost_, hmax_, supporterCost_, toGoal_;
  std::vector<int> unsatisfied_, pcf_, stack_, level_, cut_;
  std::vector<char> status_;
  std::vector<long> popped_;  // when each fact was last expanded (ties)
  long pops_ = 0;
  std::vector<Entry> queue_;  // a binary heap, smallest first
};

}  // namespace peis::meta
