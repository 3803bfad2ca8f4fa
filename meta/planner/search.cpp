// Branch and bound over the producer of each required slot (see search.h).
#include "planner/search.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <queue>

namespace peis::meta::detail {
namespace {
constexpr double kEpsilon = 1e-9;
}

struct PartSearch::State {
  const Part& part;
  std::vector<char> active;
  std::vector<int> assigned;  // option per slot, -1 none
  std::vector<int> required;  // how many active users (or the goal) need it
  std::vector<int> banned;    // reasons an instance may not be activated
  double g = 0;
  std::vector<int> mark, seen;  // for the cycle check
  int epoch = 0;
  bool dag = false;  // no cycle is possible at all: skip the check

  explicit State(const Part& p)
      : part(p),
        active(p.insts.size(), 0),
        assigned(p.slots.size(), -1),
        required(p.slots.size(), 0),
        banned(p.insts.size(), 0),
        mark(p.insts.size(), 0),
        seen(p.insts.size(), 0) {
    for (int s = 0; s < static_cast<int>(p.slots.size()); ++s) {
      if (p.slots[s].goal) require(s, +1);
    }
  }

  void require(int s, int delta) {
    const bool before = required[s] > 0;
    required[s] += delta;
    const bool after = required[s] > 0;
    if (before == after) return;
    for (int c : part.slots[s].clashes) {
      for (int u : part.slots[c].users) banned[u] += after ? 1 : -1;
    }
  }

  bool viable(int inst) const { return active[inst] || banned[inst] == 0; }

  // True when making `producer` fill `slot` closes a cycle: the producer
  // depends (through assigned slots) on an active user of the slot.
  bool closesCycle(int slot, int producer) {
    if (dag) return false;
    for (int t : part.insts[producer].slots) {
      if (t == slot) return true;  // it would feed itself
    }
    ++epoch;
    for (int u : part.slots[slot].users) {
      if (active[u]) mark[u] = epoch;
    }
    if (mark[producer] == epoch) return true;
    std::vector<int> stack{producer};
    seen[producer] = epoch;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      for (int t : part.insts[i].slots) {
        if (assigned[t] < 0) continue;
        const int q = part.slots[t].options[assigned[t]].inst;
        if (mark[q] == epoch) return true;
        if (seen[q] != epoch) {
          seen[q] = epoch;
          stack.push_back(q);
        }
      }
    }
    return false;
  }

  // Returns whether the producer was activated by this step (for undo).
  bool apply(int s, int k) {
    const auto& o = part.slots[s].options[k];
    assigned[s] = k;
    g += o.link;
    if (active[o.inst]) return false;
    active[o.inst] = 1;
    g += part.insts[o.inst].cost;
    for (int e : part.insts[o.inst].exclusive) ++banned[e];
    for (int t : part.insts[o.inst].slots) require(t, +1);
    return true;
  }

  void undo(int s, int k, bool activated) {
    const auto& o = part.slots[s].options[k];
    assigned[s] = -1;
    g -= o.link;
    if (!activated) return;
    active[o.inst] = 0;
    g -= part.insts[o.inst].cost;
    for (int e : part.insts[o.inst].exclusive) --banned[e];
    for (int t : part.insts[o.inst].slots) require(t, -1);
  }
};

namespace {

// The largest u with every cost an integer multiple of u (a denominator up
// to 1000, a common one up to 10^6), or 0 when there is none.
double costUnit(const std::vector<double>& costs) {
  constexpr double kTolerance = 1e-9;
  auto integral = [&](double x) { return std::abs(x - std::round(x)) <= kTolerance * std::max(1.0, std::abs(x)); };
  long long common = 1;  // the least common denominator
  for (double c : costs) {
    long long d = 1;
    while (d <= 1000 && !integral(c * static_cast<double>(d))) ++d;
    if (d > 1000) return 0;
    common = std::lcm(common, d);
    if (common > 1000000) return 0;
  }
  long long divisor = 0;
  for (double c : costs) {
    const double scaled = c * static_cast<double>(common);
    if (std::abs(scaled) > 1e15) return 0;
    divisor = std::gcd(divisor, static_cast<long long>(std::llround(scaled)));
  }
  return divisor > 0 ? static_cast<double>(divisor) / static_cast<double>(common) : 0;
}

}  // namespace

PartSearch::PartSearch(const Part& part) : part_(part) {
  const int slots = static_cast<int>(part.slots.size());
  const int insts = static_cast<int>(part.insts.size());
  task_.facts = slots + insts;
  for (int i = 0; i < insts; ++i) task_.actions.push_back({part.insts[i].slots, {slots + i}});
  for (int s = 0; s < slots; ++s) {
    linkBase_.push_back(static_cast<int>(task_.actions.size()));
    for (const auto& o : part.slots[s].options) task_.actions.push_back({{slots + o.inst}, {s}});
  }
  // Can any cycle of producers form at all? (Usually not: then no cycle checks.)
  {
    std::vector<int> colour(insts, 0);
    bool cyclic = false;
    std::function<void(int)> visit = [&](int i) {
      colour[i] = 1;
      for (int s : part.insts[i].slots) {
        for (const auto& o : part.slots[s].options) {
          if (colour[o.inst] == 1) cyclic = true;
          if (colour[o.inst] == 0) visit(o.inst);
        }
      }
      colour[i] = 2;
    };
    for (int i = 0; i < insts && !cyclic; ++i) {
      if (colour[i] == 0) visit(i);
    }
    dag_ = !cyclic;
  }
  // Costs that are all multiples of one unit (integers, tenths) make every
  // configuration's cost one too: a better one is at least a unit cheaper.
  {
    std::vector<double> all;
    for (const auto& inst : part.insts) all.push_back(inst.cost);
    for (const auto& slot : part.slots) {
      for (const auto& o : slot.options) all.push_back(o.link);
    }
    const double unit = costUnit(all);
    slack_ = unit > 0 ? unit * (1 - 1e-6) : kEpsilon;
  }
  // h_add of each instance (generalised Dijkstra), to try cheap producers first.
  estimate_.assign(insts, kInfinity);
  std::vector<double> slotValue(slots, kInfinity), sum(insts, 0);
  std::vector<int> missing(insts);
  using Entry = std::pair<double, int>;  // value, instance
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (int i = 0; i < insts; ++i) {
    missing[i] = static_cast<int>(part.insts[i].slots.size());
    if (missing[i] == 0) queue.push({part.insts[i].cost, i});
  }
  std::vector<std::vector<std::pair<int, double>>> fills(insts);
  for (int s = 0; s < slots; ++s) {
    for (const auto& o : part.slots[s].options) fills[o.inst].push_back({s, o.link});
  }
  while (!queue.empty()) {
    const auto [value, i] = queue.top();
    queue.pop();
    if (estimate_[i] != kInfinity) continue;
    estimate_[i] = value;
    for (const auto& [s, link] : fills[i]) {
      if (slotValue[s] != kInfinity) continue;  // the first to arrive is the cheapest
      slotValue[s] = value + link;
      for (int u : part.slots[s].users) {
        sum[u] += slotValue[s];
        if (--missing[u] == 0) queue.push({part.insts[u].cost + sum[u], u});
      }
    }
  }
}

namespace {

struct Limits {
  const SearchLimits& limits;
  std::int64_t* nodes;
  bool stopped = false;
  bool hit() {
    if (stopped) return true;
    if (limits.nodeLimit > 0 && *nodes >= limits.nodeLimit) stopped = true;
    if (limits.deadline && (*nodes & 15) == 0 &&
        std::chrono::steady_clock::now() >= *limits.deadline) {
      stopped = true;
    }
    return stopped;
  }
};

}  // namespace

PartSolution PartSearch::first(const SearchLimits& limits) { return dive(limits, nullptr); }

PartSolution PartSearch::dive(const SearchLimits& limits, const std::vector<double>* guide) {
  PartSolution result;
  State state(part_);
  state.dag = dag_;
  Limits stop{limits, &result.nodes};
  // Options in order: the warm start's, then cheapest estimated (or by the
  // guide's value of their link action, the estimate breaking ties).
  auto order = [&](int s) {
    const auto& slot = part_.slots[s];
    std::vector<int> ks(slot.options.size());
    std::iota(ks.begin(), ks.end(), 0);
    auto score = [&](int k) {
      const auto& o = slot.options[k];
      const double estimate = o.link + (state.active[o.inst] ? 0.0 : estimate_[o.inst]);
      return guide ? (*guide)[linkBase_[s] + k] + 1e-6 * estimate : estimate;
    };
    std::stable_sort(ks.begin(), ks.end(), [&](int a, int b) {
      const bool wa = a == slot.warmOption, wb = b == slot.warmOption;
      if (wa != wb) return wa;
      return score(a) < score(b);
    });
    return ks;
  };
  std::function<bool()> dive = [&]() -> bool {
    ++result.nodes;
    if (stop.hit()) return false;
    int pick = -1;
    for (int s = 0; s < static_cast<int>(part_.slots.size()); ++s) {
      if (state.required[s] > 0 && state.assigned[s] < 0) {
        pick = s;
        break;
      }
    }
    if (pick < 0) return true;
    for (int k : order(pick)) {
      const int p = part_.slots[pick].options[k].inst;
      if (!state.viable(p) || state.closesCycle(pick, p)) continue;
      const bool activated = state.apply(pick, k);
      if (dive()) return true;
      state.undo(pick, k, activated);
      if (stop.stopped) return false;
    }
    return false;
  };
  if (dive()) {
    result.found = true;
    result.cost = state.g;
    result.chosen.assign(part_.slots.size(), -1);
    for (int s = 0; s < static_cast<int>(part_.slots.size()); ++s) {
      if (state.required[s] > 0) result.chosen[s] = state.assigned[s];
    }
    result.active = state.active;
  }
  return result;
}

PartSolution PartSearch::improve(PartSolution best, const SearchLimits& limits) {
  State state(part_);
  state.dag = dag_;
  LmCut lmcut(task_);
  // Every cut found in the search, a stack: cuts found below a node are
  // dropped when the search leaves it. Nodes keep the indices of theirs.
  LmCut::Landmarks pool;
  std::int64_t nodes = 0;
  Limits stop{limits, &nodes};
  const int slotCount = static_cast<int>(part_.slots.size());
  const int instCount = static_cast<int>(part_.insts.size());
  const int actionCount = static_cast<int>(task_.actions.size());
  std::vector<double> costs(actionCount), residual(actionCount), usage;
  // Options (link actions) dropped in the current branch, by reduced cost.
  std::vector<int> optionBanned(actionCount, 0);
  auto optionViable = [&](int s, int k) {
    return optionBanned[linkBase_[s] + k] == 0 && state.viable(part_.slots[s].options[k].inst);
  };
  // The remaining task's action costs: paid actions are free, actions that
  // can no longer be part of this branch are unavailable.
  // Only the scope's own actions are available: its instances and the links
  // into its slots (the other scopes' are solved apart).
  std::vector<int> slotScope(slotCount, 0), instScope(instCount, 0);
  auto fillCosts = [&](int scopeId) {
    for (int i = 0; i < instCount; ++i) {
      costs[i] = state.active[i]                                   ? 0.0
                 : !state.viable(i) || (scopeId >= 0 && instScope[i] != scopeId) ? kInfinity
                                                                   : part_.insts[i].cost;
    }
    for (int s = 0; s < slotCount; ++s) {
      const auto& slot = part_.slots[s];
      const bool mine = scopeId < 0 || slotScope[s] == scopeId;
      for (int k = 0; k < static_cast<int>(slot.options.size()); ++k) {
        double c;
        if (state.assigned[s] >= 0) {
          c = state.assigned[s] == k ? 0.0 : kInfinity;
        } else {
          c = mine && optionViable(s, k) ? slot.options[k].link : kInfinity;
        }
        costs[linkBase_[s] + k] = c;
      }
    }
  };
  // The bound of a scope: LM-cut on the task of filling its open slots,
  // the running instances' outputs given (their own open inputs are open
  // slots too), on the costs that the parent's landmarks leave: those that
  // no decision paid for still count (dead when all their actions became
  // unavailable), new cuts are found on the rest (incremental LM-cut).
  // `complete` is set when LM-cut ran to the end (then usageCosts() may be
  // asked). `scopeId` < 0: every open slot.
  std::vector<int> openGoal;
  std::vector<char> given(slotCount + instCount, 0);
  auto bound = [&](const std::vector<int>& inherited, std::vector<int>& kept, double limit,
                   int scopeId, bool* complete) {
    *complete = false;
    fillCosts(scopeId);
    openGoal.clear();
    for (int s = 0; s < slotCount; ++s) {
      if (state.required[s] > 0 && state.assigned[s] < 0 && (scopeId < 0 || slotScope[s] == scopeId)) {
        openGoal.push_back(s);
      }
    }
    // Given: what runs or is linked already, as far as the scope can use it
    // (the running producers of its slots, the linked inputs of its
    // instances); all of it for the whole part.
    if (scopeId < 0) {
      for (int i = 0; i < instCount; ++i) given[slotCount + i] = state.active[i];
      for (int t = 0; t < slotCount; ++t) given[t] = state.assigned[t] >= 0;
    } else {
      std::fill(given.begin(), given.end(), 0);
      for (int t = 0; t < slotCount; ++t) {
        if (slotScope[t] != scopeId) continue;
        if (state.assigned[t] >= 0) given[t] = 1;
        for (const auto& o : part_.slots[t].options) {
          if (state.active[o.inst]) given[slotCount + o.inst] = 1;
        }
      }
      for (int i = 0; i < instCount; ++i) {
        if (instScope[i] != scopeId) continue;
        if (state.active[i]) given[slotCount + i] = 1;
        for (int t : part_.insts[i].slots) {
          if (state.assigned[t] >= 0) given[t] = 1;
        }
      }
    }
    kept.clear();
    double h = 0;
    residual = costs;
    for (int l : inherited) {
      bool hit = false, dead = true;
      for (const int* a = pool.begin(l); a != pool.end(l); ++a) {
        hit = hit || costs[*a] == 0;
        dead = dead && costs[*a] == kInfinity;
      }
      if (hit) continue;
      if (dead) return kInfinity;
      const double c = pool.cost[l];
      h += c;
      for (const int* a = pool.begin(l); a != pool.end(l); ++a) {
        if (residual[*a] != kInfinity) residual[*a] = std::max(0.0, residual[*a] - c);
      }
      kept.push_back(l);
      if (h >= limit) return h;
    }
    const double rest = lmcut.compute(residual, given, openGoal, limit - h, &pool, &kept);
    *complete = h + rest < limit;
    return h + rest;
  };
  double incumbent = best.found ? best.cost : kInfinity;
  std::vector<int> rootLandmarks;
  bool complete = false;
  // The root's cuts with h^max afresh after each (stronger, and inherited
  // by every node); below, h^max updated from each cut (cheaper).
  const double rootBound = bound({}, rootLandmarks, incumbent, -1, &complete);
  lmcut.incremental = true;
  best.lowerBound = std::min(rootBound, incumbent);
  if (rootBound == kInfinity) {  // no configuration at all
    best.optimal = !best.found;
    best.found = false;
    return best;
  }
  // A second start: a dive that follows the root bound's usage costs (the
  // options every cheap configuration can use), polished. It often lands
  // nearer the optimum than the estimate-guided one.
  if (complete) {
    lmcut.usageCosts(usage);
    auto guided = polish(dive(limits, &usage), limits);
    if (guided.found && (!best.found || guided.cost < best.cost - slack_)) {
      guided.nodes += best.nodes;
      guided.lowerBound = best.lowerBound;
      best = std::move(guided);
      incumbent = best.cost;
    } else {
      best.nodes += guided.nodes;
    }
  }
  // The search is over scopes: the whole part, or (below an AND node) one
  // of the independent components its open slots fell into. Slots and
  // instances carry the id of the innermost scope they belong to.
  struct Scope {
    int id = 0;
    double limit = 0;       // a configuration is better when its g is below this
    std::size_t start = 0;  // the decisions before this scope began
    bool found = false;
    std::vector<std::pair<int, int>> best;  // the decisions of the best one found
  };
  int nextScope = 1;
  auto inScope = [&](const Scope& scope, int s) { return slotScope[s] == scope.id; };
  auto viableCount = [&](int s, int* only) {
    int count = 0;
    for (int k = 0; k < static_cast<int>(part_.slots[s].options.size()); ++k) {
      if (optionViable(s, k) && !state.closesCycle(s, part_.slots[s].options[k].inst)) {
        ++count;
        *only = k;
      }
    }
    return count;
  };
  // Every assignment on the current path, in order.
  struct Step {
    int slot, option;
    bool activated;
  };
  std::vector<Step> decisions;
  auto assign = [&](int s, int k) { decisions.push_back({s, k, state.apply(s, k)}); };
  auto undoTo = [&](std::size_t size) {
    while (decisions.size() > size) {
      const auto step = decisions.back();
      decisions.pop_back();
      state.undo(step.slot, step.option, step.activated);
    }
  };
  // Assignments that need no choice: a slot with one possible producer; and,
  // when no cycle is possible, a slot whose cheapest link comes from a
  // producer already running (using it can never cost more).
  auto propagate = [&](const Scope& scope) {
    bool changed = true;
    while (changed) {
      changed = false;
      for (int s = 0; s < slotCount; ++s) {
        if (state.required[s] == 0 || state.assigned[s] >= 0 || !inScope(scope, s)) continue;
        const auto& slot = part_.slots[s];
        int only = -1;
        const int count = viableCount(s, &only);
        if (count == 0) return false;
        int choice = count == 1 ? only : -1;
        if (choice < 0 && dag_) {
          double cheapest = kInfinity;
          int activeBest = -1;
          double activeLink = kInfinity;
          for (int k = 0; k < static_cast<int>(slot.options.size()); ++k) {
            const auto& o = slot.options[k];
            if (!optionViable(s, k)) continue;
            cheapest = std::min(cheapest, o.link);
            if (state.active[o.inst] && o.link < activeLink) {
              activeLink = o.link;
              activeBest = k;
            }
          }
          if (activeBest >= 0 && activeLink <= cheapest) choice = activeBest;
        }
        if (choice < 0) continue;
        assign(s, choice);
        changed = true;
      }
    }
    return true;
  };
  auto record = [&] {
    incumbent = state.g;
    best.found = true;
    best.cost = state.g;
    best.chosen.assign(slotCount, -1);
    for (int s = 0; s < slotCount; ++s) {
      if (state.required[s] > 0) best.chosen[s] = state.assigned[s];
    }
    best.active = state.active;
    // A new incumbent is often one local move from a better one.
    std::int64_t moves = best.nodes;
    best = polish(std::move(best), limits);
    nodes += best.nodes - moves;
    best.nodes = moves;
    incumbent = best.cost;
  };
  // Every open slot of the scope is filled: a better configuration of it.
  auto leaf = [&](Scope& scope) {
    if (scope.id == 0) {
      record();
      scope.limit = incumbent;
      return;
    }
    scope.found = true;
    scope.limit = state.g;
    scope.best.clear();
    for (std::size_t i = scope.start; i < decisions.size(); ++i) {
      scope.best.push_back({decisions[i].slot, decisions[i].option});
    }
  };
  // Reduced-cost fixing: an instance or an option of the scope whose every
  // use costs at least what the scope can afford is dropped for this
  // branch. Returns how many.
  struct Bans {
    std::vector<int> instances, options;
  };
  auto fix = [&](const Scope& scope, double budget, Bans& bans) {
    lmcut.usageCosts(usage);
    int dropped = 0;
    for (int i = 0; i < instCount; ++i) {
      if (instScope[i] != scope.id || state.active[i] || !state.viable(i) || usage[i] < budget) {
        continue;
      }
      ++state.banned[i];
      bans.instances.push_back(i);
      ++dropped;
    }
    for (int s = 0; s < slotCount; ++s) {
      if (state.assigned[s] >= 0 || !inScope(scope, s)) continue;
      for (int k = 0; k < static_cast<int>(part_.slots[s].options.size()); ++k) {
        const int a = linkBase_[s] + k;
        if (!optionViable(s, k) || usage[a] < budget) continue;
        ++optionBanned[a];
        bans.options.push_back(a);
        ++dropped;
      }
    }
    return dropped;
  };
  auto lift = [&](Bans& bans) {
    for (int i : bans.instances) --state.banned[i];
    for (int a : bans.options) --optionBanned[a];
  };
  // The independent components of the scope's open slots: slots joined
  // through the producers that could still fill them (not yet running),
  // those producers' own inputs, writers of one key, and clashing slots.
  // Only when no cycle can form (else a choice in one could close a cycle
  // through another).
  std::vector<int> parent(slotCount + instCount), reached;
  std::vector<int> groupOfRoot(slotCount + instCount, -1);
  std::vector<char> seen(slotCount + instCount, 0);
  auto findRoot = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  auto unite = [&](int a, int b) { parent[findRoot(a)] = findRoot(b); };
  auto components = [&](const Scope& scope) {
    std::vector<std::vector<int>> groups;  // slots first, then instances (offset slotCount)
    if (!dag_) return groups;
    reached.clear();
    for (int s = 0; s < slotCount; ++s) {
      if (state.required[s] == 0 || state.assigned[s] >= 0 || !inScope(scope, s)) continue;
      parent[s] = s;
      seen[s] = 1;
      reached.push_back(s);
    }
    const std::size_t roots = reached.size();
    for (std::size_t next = 0; next < reached.size(); ++next) {
      const int x = reached[next];
      auto visit = [&](int y) {
        if (!seen[y]) {
          seen[y] = 1;
          parent[y] = y;
          reached.push_back(y);
        }
        unite(x, y);
      };
      if (x < slotCount) {
        const auto& options = part_.slots[x].options;
        for (int k = 0; k < static_cast<int>(options.size()); ++k) {
          if (optionViable(x, k) && !state.active[options[k].inst]) visit(slotCount + options[k].inst);
        }
      } else {
        for (int t : part_.insts[x - slotCount].slots) {
          if (state.assigned[t] < 0) visit(t);
        }
      }
    }
    for (int x : reached) {
      if (x < slotCount) {
        for (int c : part_.slots[x].clashes) {
          if (seen[c]) unite(x, c);
        }
      } else {
        for (int e : part_.insts[x - slotCount].exclusive) {
          if (seen[slotCount + e]) unite(x, slotCount + e);
        }
      }
    }
    // Groups by representative, numbered in the order of their first open slot.
    int count = 0;
    for (std::size_t i = 0; i < roots; ++i) {
      const int r = findRoot(reached[i]);
      if (groupOfRoot[r] < 0) groupOfRoot[r] = count++;
    }
    if (count >= 2) {
      groups.resize(count);
      for (int x : reached) {
        const int gr = groupOfRoot[findRoot(x)];
        if (gr >= 0) groups[gr].push_back(x);  // (every member reaches an open slot)
      }
    }
    for (std::size_t i = 0; i < roots; ++i) groupOfRoot[findRoot(reached[i])] = -1;
    for (int x : reached) seen[x] = 0;
    return groups;
  };
  std::function<void(Scope&, const std::vector<int>&)> node;
  // An AND node: the open slots of `scope` fell into independent groups.
  // Each is solved to its optimum on its own (with what the others must
  // cost at least subtracted from the limit); together they fill the scope.
  auto andNode = [&](Scope& scope, std::vector<std::vector<int>>& groups,
                     const std::vector<int>& found) {
    const double g0 = state.g;
    const int poolSize = pool.size();
    const int count = static_cast<int>(groups.size());
    std::vector<Scope> parts(count);
    std::vector<std::vector<int>> landmarks(count);
    std::vector<double> lower(count);
    double sum = 0;
    for (int c = 0; c < count; ++c) {
      auto& sub = parts[c];
      sub.id = nextScope++;
      for (int x : groups[c]) {
        if (x < slotCount) {
          slotScope[x] = sub.id;
        } else {
          instScope[x - slotCount] = sub.id;
        }
      }
    }
    // The node's landmarks whose actions all belong to one group are that
    // group's: every plan of it hits them, and their costs still partition
    // (a landmark across groups is dropped). They bound and seed each group.
    auto groupOf = [&](int a) {
      if (a < instCount) return instScope[a];
      const int s = static_cast<int>(std::upper_bound(linkBase_.begin(), linkBase_.end(), a) -
                                     linkBase_.begin()) - 1;
      return slotScope[s];
    };
    std::vector<std::vector<int>> attributed(count);
    for (int l : found) {
      const int first = groupOf(*pool.begin(l));
      bool one = true;
      for (const int* a = pool.begin(l); a != pool.end(l) && one; ++a) one = groupOf(*a) == first;
      if (!one) continue;
      for (int c = 0; c < count; ++c) {
        if (parts[c].id == first) attributed[c].push_back(l);
      }
    }
    // Each group's bound: its landmarks and new cuts for what they leave.
    for (int c = 0; c < count; ++c) {
      bool complete = false;
      lower[c] = bound(attributed[c], landmarks[c], kInfinity, parts[c].id, &complete);
      sum += lower[c];
    }
    bool useful = g0 + sum < scope.limit - slack_;
    // The smaller groups first: quickly solved, they tighten the others' limits.
    std::vector<int> order(count);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return groups[a].size() < groups[b].size(); });
    for (int c : order) {
      if (!useful) break;
      auto& sub = parts[c];
      sub.limit = scope.limit - (sum - lower[c]);
      sub.start = decisions.size();
      node(sub, landmarks[c]);
      if (stop.stopped || !sub.found) {
        useful = false;
        break;
      }
      const double cost = sub.limit - g0;  // the group's optimum
      sum += cost - lower[c];
      lower[c] = cost;
    }
    if (useful && !stop.stopped && g0 + sum < scope.limit - slack_) {
      const std::size_t before = decisions.size();
      for (const auto& sub : parts) {
        for (const auto& [s, k] : sub.best) assign(s, k);
      }
      leaf(scope);
      undoTo(before);
    }
    for (int c = 0; c < count; ++c) {
      for (int x : groups[c]) {
        if (x < slotCount) {
          slotScope[x] = scope.id;
        } else {
          instScope[x - slotCount] = scope.id;
        }
      }
    }
    pool.truncate(poolSize);
  };
  node = [&](Scope& scope, const std::vector<int>& inherited0) {
    ++nodes;
    if (stop.hit()) return;
    const std::size_t decided = decisions.size();
    Bans bans;
    const int poolSize = pool.size();
    std::vector<int> landmarks;
    const std::vector<int>* inherited = &inherited0;
    std::vector<int> scratch;
    int pick = -1;
    auto leave = [&] {
      undoTo(decided);
      lift(bans);
      pool.truncate(poolSize);
    };
    // Propagate, pick the most constrained open slot, bound; then drop what
    // cannot be part of a better configuration, and when that forces
    // choices, propagate and bound once more (on the same landmarks).
    for (int round = 0;; ++round) {
      const std::size_t assignedBefore = decisions.size();
      if (!propagate(scope) || state.g >= scope.limit - slack_) return leave();
      pick = -1;
      int fewest = 0;
      for (int s = 0; s < slotCount; ++s) {
        if (state.required[s] == 0 || state.assigned[s] >= 0 || !inScope(scope, s)) continue;
        int only = -1;
        const int count = viableCount(s, &only);
        if (pick < 0 || count < fewest) {
          pick = s;
          fewest = count;
        }
      }
      if (pick < 0) {
        leaf(scope);
        return leave();
      }
      if (round > 0 && decisions.size() == assignedBefore) break;  // the bans forced nothing
      const double budget = scope.limit - state.g - slack_;
      bool complete = false;
      const double h = bound(*inherited, landmarks, budget, scope.id, &complete);
      if (h >= budget) return leave();
      if (!complete || round >= 1 || fix(scope, budget - h, bans) == 0) break;
      scratch = landmarks;
      inherited = &scratch;
    }
    if (auto groups = components(scope); groups.size() >= 2) {
      andNode(scope, groups, landmarks);
      return leave();
    }
    const auto& slot = part_.slots[pick];
    std::vector<std::pair<double, int>> ks;
    for (int k = 0; k < static_cast<int>(slot.options.size()); ++k) {
      const auto& o = slot.options[k];
      if (!optionViable(pick, k) || state.closesCycle(pick, o.inst)) continue;
      // The cheapest by this node's usage costs first, then by estimate.
      const double estimate = o.link + (state.active[o.inst] ? 0.0 : estimate_[o.inst]);
      ks.push_back({usage[linkBase_[pick] + k] + 1e-6 * estimate, k});
    }
    std::stable_sort(ks.begin(), ks.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    // When no cycle can form, a configuration in which `pick` takes option
    // k while the producer of an earlier sibling with a link no dearer runs
    // is never better than one of that sibling's (switch the slot to it):
    // such a sibling is skipped when its producer runs already, and its
    // producer is banned in the subtree otherwise.
    std::vector<int> bannedHere;
    for (std::size_t j = 0; j < ks.size(); ++j) {
      const auto& o = slot.options[ks[j].second];
      bool dominated = false;
      bannedHere.clear();
      for (std::size_t i = 0; i < j && dag_ && !dominated; ++i) {
        const auto& earlier = slot.options[ks[i].second];
        if (earlier.link > o.link || earlier.inst == o.inst) continue;
        if (state.active[earlier.inst]) {
          dominated = true;
        } else {
          ++state.banned[earlier.inst];
          bannedHere.push_back(earlier.inst);
        }
      }
      if (!dominated && state.viable(o.inst)) {
        const std::size_t before = decisions.size();
        assign(pick, ks[j].second);
        node(scope, landmarks);
        undoTo(before);
      }
      for (int i : bannedHere) --state.banned[i];
      if (stop.stopped) break;
    }
    leave();
  };
  Scope top;
  top.limit = incumbent;
  node(top, rootLandmarks);
  best.nodes += nodes;
  if (!stop.stopped) {
    best.optimal = true;
    best.lowerBound = best.found ? best.cost : kInfinity;
  }
  return best;
}

}  // namespace peis::meta::detail
