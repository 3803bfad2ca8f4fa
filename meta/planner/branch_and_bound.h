// Branch and bound to the optimum of one part (PartSearch::improve): depth
// first over the producer of the most constrained open slot, each node
// bounded by incremental LM-cut, with forced choices propagated, dominated
// siblings skipped, instances and options dropped by reduced cost, and AND
// nodes where the open slots fall into independent groups. How and why:
// docs/configuration.md, "How the planner works". Internal to the planner.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "planner/lmcut.h"
#include "planner/part_state.h"
#include "planner/search.h"

namespace peis::meta::detail {

class BranchAndBound {
 public:
  BranchAndBound(PartSearch& search, const SearchLimits& limits);
  // Improves `best` (which may be !found) to the optimum, or to the limits.
  PartSolution run(PartSolution best);

 private:
  // The whole part, or (below an AND node) one of the independent groups
  // its open slots fell into. Slots and instances carry the id of the
  // innermost scope they belong to.
  struct Scope {
    int id = 0;
    double limit = 0;       // a configuration is better when its g is below this
    std::size_t start = 0;  // the decisions before this scope began
    bool found = false;
    std::vector<std::pair<int, int>> best;  // the decisions of the best one found
  };
  struct Step {
    int slot, option;
    bool activated;
  };
  struct Bans {
    std::vector<int> instances, options;
  };

  bool optionViable(int s, int k) const;
  bool inScope(const Scope& scope, int s) const { return slotScope_[s] == scope.id; }
  int viableCount(int s, int* only);
  void fillCosts(int scopeId);
  double bound(const std::vector<int>& inherited, std::vector<int>& kept, double limit, int scopeId,
               bool* complete);
  void assign(int s, int k);
  void undoTo(std::size_t size);
  bool propagate(const Scope& scope, int* pick);
  void record();
  void leaf(Scope& scope);
  int fix(const Scope& scope, double budget, Bans& bans);
  void lift(Bans& bans);
  int findRoot(int x);
  std::vector<std::vector<int>> components(const Scope& scope);
  void andNode(Scope& scope, std::vector<std::vector<int>>& groups, const std::vector<int>& found);
  void node(Scope& scope, const std::vector<int>& inherited);

  PartSearch& search_;
  const Part& part_;
  const SearchLimits& limits_;
  const int slotCount_, instCount_;
  PartState state_;
  LmCut lmcut_;
  // Every cut found in the search, a stack: cuts found below a node are
  // dropped when the search leaves it. Nodes keep the indices of theirs.
  LmCut::Landmarks pool_;
  std::int64_t nodes_ = 0;
  Stopper stop_;
  PartSolution best_;
  double incumbent_ = kInfinity;
  std::vector<double> costs_, residual_, usage_;
  std::vector<int> optionBanned_;  // options dropped in the current branch, by reduced cost
  std::vector<int> slotScope_, instScope_;
  int nextScope_ = 1;
  std::vector<int> openGoal_;
  std::vector<char> given_;
  std::vector<Step> decisions_;  // every assignment on the current path, in order
  // Union-find over slots and instances (offset slotCount_), for components().
  std::vector<int> parent_, reached_, groupOfRoot_;
  std::vector<char> seen_;
};

}  // namespace peis::meta::detail
