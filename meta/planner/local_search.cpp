// Local search on a valid configuration of one part (PartSearch::polish, see
// search.h): a better incumbent makes branch and bound prune (and drop
// options by reduced cost) far earlier. Two moves, first improvement, until
// none improves or the budget is spent:
//   drop p:  the slots p fills take other producers (greedily, preferring
//            what already runs); whatever nothing uses any more stops;
//   add q:   q runs (its inputs filled greedily) and takes over every slot
//            it can fill with a link no dearer; what is left unused stops.
// Only for parts where no cycle of producers can form (then any choice of
// producers is acyclic); other parts keep their first configuration.
#include <algorithm>

#include "planner/search.h"

namespace peis::meta::detail {
namespace {

constexpr double kEpsilon = 1e-9;

// A configuration as counters, so that producers that lose their last use
// stop (and release their own inputs) at once.
struct Solution {
  std::vector<char> active;
  std::vector<int> assigned;  // option per slot, -1 none
  std::vector<int> required;  // active users of the slot, +1 for a goal
  std::vector<int> uses;      // slots assigned to the instance
  double g = 0;
};

class Moves {
 public:
  Moves(const Part& part, const std::vector<double>& estimate)
      : part_(part), estimate_(estimate), fills_(part.insts.size()) {
    for (int s = 0; s < static_cast<int>(part.slots.size()); ++s) {
      const auto& options = part.slots[s].options;
      for (int k = 0; k < static_cast<int>(options.size()); ++k) {
        fills_[options[k].inst].push_back({s, k});
      }
    }
  }

  Solution from(const PartSolution& solution) const {
    Solution x;
    const int slots = static_cast<int>(part_.slots.size());
    x.active = solution.active;
    x.assigned = solution.chosen;
    x.required.assign(slots, 0);
    x.uses.assign(part_.insts.size(), 0);
    x.g = solution.cost;
    for (int s = 0; s < slots; ++s) {
      if (part_.slots[s].goal) ++x.required[s];
      if (x.assigned[s] >= 0) ++x.uses[part_.slots[s].options[x.assigned[s]].inst];
    }
    for (int i = 0; i < static_cast<int>(part_.insts.size()); ++i) {
      if (!x.active[i]) continue;
      for (int t : part_.insts[i].slots) ++x.required[t];
    }
    return x;
  }

  // Back to a PartSolution, its cost summed afresh (no drift from moves).
  void store(const Solution& x, PartSolution& solution) const {
    solution.active = x.active;
    solution.chosen.assign(part_.slots.size(), -1);
    solution.cost = 0;
    for (int i = 0; i < static_cast<int>(part_.insts.size()); ++i) {
      if (x.active[i]) solution.cost += part_.insts[i].cost;
    }
    for (int s = 0; s < static_cast<int>(part_.slots.size()); ++s) {
      if (x.required[s] == 0) continue;
      solution.chosen[s] = x.assigned[s];
      solution.cost += part_.slots[s].options[x.assigned[s]].link;
    }
  }

  // Every required slot of `x` that has no producer, filled greedily
  // without `banned`; false when one cannot be.
  bool fill(Solution& x, int banned) {
    while (!open_.empty()) {
      const int s = open_.back();
      open_.pop_back();
      if (x.required[s] == 0 || x.assigned[s] >= 0) continue;
      const auto& options = part_.slots[s].options;
      int choice = -1;
      double best = kInfinity;
      for (int k = 0; k < static_cast<int>(options.size()); ++k) {
        const int q = options[k].inst;
        if (q == banned || !viable(x, q)) continue;
        const double score = options[k].link + (x.active[q] ? 0.0 : marginal(x, q));
        if (score < best - kEpsilon) {
          best = score;
          choice = k;
        }
      }
      if (choice < 0) return false;
      assign(x, s, choice);
    }
    return true;
  }

  bool drop(Solution& x, int p) {
    open_.clear();
    for (const auto& [s, k] : fills_[p]) {
      if (x.assigned[s] != k) continue;
      unassign(x, s);
      open_.push_back(s);
    }
    return fill(x, p);
  }

  bool add(Solution& x, int q) {
    if (x.active[q] || !viable(x, q)) return false;
    open_.clear();
    activate(x, q);
    if (!fill(x, -1)) return false;
    for (const auto& [s, k] : fills_[q]) {
      if (x.required[s] == 0 || x.assigned[s] < 0 || x.assigned[s] == k) continue;
      const auto& options = part_.slots[s].options;
      if (options[k].link > options[x.assigned[s]].link + kEpsilon) continue;
      unassign(x, s);
      assign(x, s, k);
    }
    return x.uses[q] > 0;
  }

 private:
  bool viable(const Solution& x, int q) const {
    if (x.active[q]) return true;
    for (int e : part_.insts[q].exclusive) {
      if (x.active[e]) return false;
    }
    for (int t : part_.insts[q].slots) {
      for (int c : part_.slots[t].clashes) {
        if (x.required[c] > 0) return false;
      }
    }
    return true;
  }

  // What running q would add: its cost and, for each input not yet
  // supplied, the cheapest estimated producer.
  double marginal(const Solution& x, int q) const {
    double sum = part_.insts[q].cost;
    for (int t : part_.insts[q].slots) {
      if (x.required[t] > 0 && x.assigned[t] >= 0) continue;
      double cheapest = kInfinity;
      for (const auto& o : part_.slots[t].options) {
        cheapest = std::min(cheapest, o.link + (x.active[o.inst] ? 0.0 : estimate_[o.inst]));
      }
      sum += cheapest;
    }
    return sum;
  }

  // Every change is journalled, so that a move that does not pay is undone
  // in the time it took (no copy of the configuration per move).
  enum Field : char { kActive, kAssigned, kRequired, kUses };
  struct Change {
    Field field;
    int index, old;
  };
  void set(Solution& x, Field field, int index, int value) {
    int* slot = nullptr;
    int old = 0;
    switch (field) {
      case kActive:
        old = x.active[index];
        x.active[index] = static_cast<char>(value);
        break;
      case kAssigned:
        slot = &x.assigned[index];
        break;
      case kRequired:
        slot = &x.required[index];
        break;
      case kUses:
        slot = &x.uses[index];
        break;
    }
    if (slot) {
      old = *slot;
      *slot = value;
    }
    journal_.push_back({field, index, old});
  }

  void activate(Solution& x, int i) {
    set(x, kActive, i, 1);
    x.g += part_.insts[i].cost;
    for (int t : part_.insts[i].slots) {
      set(x, kRequired, t, x.required[t] + 1);
      if (x.required[t] == 1) open_.push_back(t);
    }
  }

  void deactivate(Solution& x, int i) {
    set(x, kActive, i, 0);
    x.g -= part_.insts[i].cost;
    for (int t : part_.insts[i].slots) {
      set(x, kRequired, t, x.required[t] - 1);
      if (x.required[t] == 0 && x.assigned[t] >= 0) unassign(x, t);
    }
  }

  void assign(Solution& x, int s, int k) {
    const auto& o = part_.slots[s].options[k];
    set(x, kAssigned, s, k);
    x.g += o.link;
    set(x, kUses, o.inst, x.uses[o.inst] + 1);
    if (!x.active[o.inst]) activate(x, o.inst);
  }

  void unassign(Solution& x, int s) {
    const auto& o = part_.slots[s].options[x.assigned[s]];
    set(x, kAssigned, s, -1);
    x.g -= o.link;
    set(x, kUses, o.inst, x.uses[o.inst] - 1);
    if (x.uses[o.inst] == 0) deactivate(x, o.inst);
  }

 public:
  std::size_t mark() const { return journal_.size(); }
  // Back to the configuration at `mark` (with its cost `g`).
  void undo(Solution& x, std::size_t mark, double g) {
    while (journal_.size() > mark) {
      const auto c = journal_.back();
      journal_.pop_back();
      switch (c.field) {
        case kActive:
          x.active[c.index] = static_cast<char>(c.old);
          break;
        case kAssigned:
          x.assigned[c.index] = c.old;
          break;
        case kRequired:
          x.required[c.index] = c.old;
          break;
        case kUses:
          x.uses[c.index] = c.old;
          break;
      }
    }
    x.g = g;
  }
  void commit() { journal_.clear(); }

 private:
  const Part& part_;
  const std::vector<double>& estimate_;
  std::vector<std::vector<std::pair<int, int>>> fills_;  // instance -> (slot, option)
  std::vector<int> open_;
  std::vector<Change> journal_;
};

}  // namespace

PartSolution PartSearch::polish(PartSolution start, const SearchLimits& limits) {
  if (!start.found || !dag_) return start;
  Moves moves(part_, estimate_);
  Solution current = moves.from(start);
  const int insts = static_cast<int>(part_.insts.size());
  std::int64_t tried = 0;
  auto outOfTime = [&] {
    return limits.deadline && (tried & 15) == 0 &&
           std::chrono::steady_clock::now() >= *limits.deadline;
  };
  // A generous cap on the moves, for pathological models.
  const std::int64_t cap = 50 * static_cast<std::int64_t>(insts) + 1000;
  bool improved = true;
  while (improved && tried < cap) {
    improved = false;
    for (int i = 0; i < insts && !improved; ++i) {
      ++tried;
      if (outOfTime()) break;
      const double g = current.g;
      const bool ok = current.active[i] ? moves.drop(current, i) : moves.add(current, i);
      if (ok && current.g < g - kEpsilon) {
        moves.commit();
        improved = true;
      } else {
        moves.undo(current, 0, g);
      }
    }
  }
  moves.store(current, start);
  start.nodes += tried;
  return start;
}

}  // namespace peis::meta::detail
