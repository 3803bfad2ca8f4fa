// Branch and bound over the producer of each required slot, with AND nodes
// (see branch_and_bound.h).
#include "planner/branch_and_bound.h"

#include <algorithm>
#include <numeric>

namespace peis::meta::detail {

BranchAndBound::BranchAndBound(PartSearch& search, const SearchLimits& limits)
    : search_(search),
      part_(search.part_),
      limits_(limits),
      slotCount_(static_cast<int>(search.part_.slots.size())),
      instCount_(static_cast<int>(search.part_.insts.size())),
      state_(search.part_),
      lmcut_(search.task_),
      stop_{limits, &nodes_},
      costs_(search.task_.actions.size()),
      residual_(search.task_.actions.size()),
      optionBanned_(search.task_.actions.size(), 0),
      slotScope_(slotCount_, 0),
      instScope_(instCount_, 0),
      given_(slotCount_ + instCount_, 0),
      parent_(slotCount_ + instCount_),
      groupOfRoot_(slotCount_ + instCount_, -1),
      seen_(slotCount_ + instCount_, 0) {
  state_.dag = search.dag_;
}

bool BranchAndBound::optionViable(int s, int k) const {
  return optionBanned_[search_.linkBase_[s] + k] == 0 &&
         state_.viable(part_.slots[s].options[k].inst);
}

int BranchAndBound::viableCount(int s, int* only) {
  int count = 0;
  for (int k = 0; k < static_cast<int>(part_.slots[s].options.size()); ++k) {
    if (optionViable(s, k) && !state_.closesCycle(s, part_.slots[s].options[k].inst)) {
      ++count;
      *only = k;
    }
  }
  return count;
}

// The remaining task's action costs: paid actions are free, actions that
// can no longer be part of this branch are unavailable, and so are the
// other scopes' (their instances, the links into their slots).
void BranchAndBound::fillCosts(int scopeId) {
  for (int i = 0; i < instCount_; ++i) {
    if (state_.active[i]) {
      costs_[i] = 0;
    } else if (!state_.viable(i) || (scopeId >= 0 && instScope_[i] != scopeId)) {
      costs_[i] = kInfinity;
    } else {
      costs_[i] = part_.insts[i].cost;
    }
  }
  for (int s = 0; s < slotCount_; ++s) {
    const auto& slot = part_.slots[s];
    const bool mine = scopeId < 0 || slotScope_[s] == scopeId;
    for (int k = 0; k < static_cast<int>(slot.options.size()); ++k) {
      double c;
      if (state_.assigned[s] >= 0) {
        c = state_.assigned[s] == k ? 0.0 : kInfinity;
      } else {
        c = mine && optionViable(s, k) ? slot.options[k].link : kInfinity;
      }
      costs_[search_.linkBase_[s] + k] = c;
    }
  }
}

// The bound of a scope: LM-cut on the task of filling its open slots, the
// running instances' outputs given (their own open inputs are open slots
// too), on the costs that the inherited landmarks leave: those that no
// decision paid for still count (dead when all their actions became
// unavailable), new cuts are found on the rest. `complete` is set when
// LM-cut ran to the end (then usageCosts() may be asked). `scopeId` < 0:
// every open slot.
double BranchAndBound::bound(const std::vector<int>& inherited, std::vector<int>& kept,
                             double limit, int scopeId, bool* complete) {
  *complete = false;
  fillCosts(scopeId);
  openGoal_.clear();
  for (int s = 0; s < slotCount_; ++s) {
    if (state_.required[s] > 0 && state_.assigned[s] < 0 &&
        (scopeId < 0 || slotScope_[s] == scopeId)) {
      openGoal_.push_back(s);
    }
  }
  // Given: what runs or is linked already, as far as the scope can use it
  // (the running producers of its slots, the linked inputs of its
  // instances); all of it for the whole part.
  if (scopeId < 0) {
    for (int i = 0; i < instCount_; ++i) given_[slotCount_ + i] = state_.active[i];
    for (int t = 0; t < slotCount_; ++t) given_[t] = state_.assigned[t] >= 0;
  } else {
    std::fill(given_.begin(), given_.end(), 0);
    for (int t = 0; t < slotCount_; ++t) {
      if (slotScope_[t] != scopeId) continue;
      if (state_.assigned[t] >= 0) given_[t] = 1;
      for (const auto& o : part_.slots[t].options) {
        if (state_.active[o.inst]) given_[slotCount_ + o.inst] = 1;
      }
    }
    for (int i = 0; i < instCount_; ++i) {
      if (instScope_[i] != scopeId) continue;
      if (state_.active[i]) given_[slotCount_ + i] = 1;
      for (int t : part_.insts[i].slots) {
        if (state_.assigned[t] >= 0) given_[t] = 1;
      }
    }
  }
  kept.clear();
  double h = 0;
  residual_ = costs_;
  for (int l : inherited) {
    bool hit = false, dead = true;
    for (const int* a = pool_.begin(l); a != pool_.end(l); ++a) {
      hit = hit || costs_[*a] == 0;
      dead = dead && costs_[*a] == kInfinity;
    }
    if (hit) continue;
    if (dead) return kInfinity;
    const double c = pool_.cost[l];
    h += c;
    for (const int* a = pool_.begin(l); a != pool_.end(l); ++a) {
      if (residual_[*a] != kInfinity) residual_[*a] = std::max(0.0, residual_[*a] - c);
    }
    kept.push_back(l);
    if (h >= limit) return h;
  }
  const double rest = lmcut_.compute(residual_, given_, openGoal_, limit - h, &pool_, &kept);
  *complete = h + rest < limit;
  return h + rest;
}

void BranchAndBound::assign(int s, int k) { decisions_.push_back({s, k, state_.apply(s, k)}); }

void BranchAndBound::undoTo(std::size_t size) {
  while (decisions_.size() > size) {
    const auto step = decisions_.back();
    decisions_.pop_back();
    state_.undo(step.slot, step.option, step.activated);
  }
}

// Assignments that need no choice: a slot with one possible producer; and,
// when no cycle is possible, a slot whose cheapest link comes from a
// producer already running (using it can never cost more). False when a
// slot has no producer left. `pick`: the open slot with the fewest
// producers left (the first of them), -1 when none is open.
bool BranchAndBound::propagate(const Scope& scope, int* pick) {
  bool changed = true;
  while (changed) {
    changed = false;
    *pick = -1;
    int fewest = 0;
    for (int s = 0; s < slotCount_; ++s) {
      if (state_.required[s] == 0 || state_.assigned[s] >= 0 || !inScope(scope, s)) continue;
      const auto& slot = part_.slots[s];
      int only = -1;
      const int count = viableCount(s, &only);
      if (count == 0) return false;
      int choice = count == 1 ? only : -1;
      if (choice < 0 && search_.dag_) {
        double cheapest = kInfinity;
        int activeBest = -1;
        double activeLink = kInfinity;
        for (int k = 0; k < static_cast<int>(slot.options.size()); ++k) {
          const auto& o = slot.options[k];
          if (!optionViable(s, k)) continue;
          cheapest = std::min(cheapest, o.link);
          if (state_.active[o.inst] && o.link < activeLink) {
            activeLink = o.link;
            activeBest = k;
          }
        }
        if (activeBest >= 0 && activeLink <= cheapest) choice = activeBest;
      }
      if (choice < 0) {
        if (*pick < 0 || count < fewest) {
          *pick = s;
          fewest = count;
        }
        continue;
      }
      assign(s, choice);
      changed = true;
    }
  }
  return true;
}

// A better configuration of the whole part: the new incumbent, polished
// (a new incumbent is often one local move from a better one).
void BranchAndBound::record() {
  best_.found = true;
  best_.cost = state_.g;
  best_.chosen.assign(slotCount_, -1);
  for (int s = 0; s < slotCount_; ++s) {
    if (state_.required[s] > 0) best_.chosen[s] = state_.assigned[s];
  }
  best_.active = state_.active;
  const std::int64_t moves = best_.nodes;
  best_ = search_.polish(std::move(best_), limits_);
  nodes_ += best_.nodes - moves;
  best_.nodes = moves;
  incumbent_ = best_.cost;
}

// Every open slot of the scope is filled: a better configuration of it.
void BranchAndBound::leaf(Scope& scope) {
  if (scope.id == 0) {
    record();
    scope.limit = incumbent_;
    return;
  }
  scope.found = true;
  scope.limit = state_.g;
  scope.best.clear();
  for (std::size_t i = scope.start; i < decisions_.size(); ++i) {
    scope.best.push_back({decisions_[i].slot, decisions_[i].option});
  }
}

// Reduced-cost fixing: an instance or an option of the scope whose every
// use costs at least what the scope can afford (LmCut::usageCosts) is
// dropped for this branch. Returns how many.
int BranchAndBound::fix(const Scope& scope, double budget, Bans& bans) {
  lmcut_.usageCosts(usage_);
  int dropped = 0;
  for (int i = 0; i < instCount_; ++i) {
    if (instScope_[i] != scope.id || state_.active[i] || !state_.viable(i) || usage_[i] < budget) {
      continue;
    }
    ++state_.banned[i];
    bans.instances.push_back(i);
    ++dropped;
  }
  for (int s = 0; s < slotCount_; ++s) {
    if (state_.assigned[s] >= 0 || !inScope(scope, s)) continue;
    for (int k = 0; k < static_cast<int>(part_.slots[s].options.size()); ++k) {
      const int a = search_.linkBase_[s] + k;
      if (!optionViable(s, k) || usage_[a] < budget) continue;
      ++optionBanned_[a];
      bans.options.push_back(a);
      ++dropped;
    }
  }
  return dropped;
}

void BranchAndBound::lift(Bans& bans) {
  for (int i : bans.instances) --state_.banned[i];
  for (int a : bans.options) --optionBanned_[a];
}

int BranchAndBound::findRoot(int x) {
  while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
  return x;
}

// The independent groups of the scope's open slots: slots joined through
// the producers that could still fill them (not yet running), those
// producers' own open inputs, writers of one key and clashing slots.
// Only when no cycle can form (else a choice in one group could close a
// cycle through another). Slots first, then instances (offset slotCount_).
std::vector<std::vector<int>> BranchAndBound::components(const Scope& scope) {
  std::vector<std::vector<int>> groups;
  if (!search_.dag_) return groups;
  auto unite = [&](int a, int b) { parent_[findRoot(a)] = findRoot(b); };
  reached_.clear();
  for (int s = 0; s < slotCount_; ++s) {
    if (state_.required[s] == 0 || state_.assigned[s] >= 0 || !inScope(scope, s)) continue;
    parent_[s] = s;
    seen_[s] = 1;
    reached_.push_back(s);
  }
  const std::size_t roots = reached_.size();
  for (std::size_t next = 0; next < reached_.size(); ++next) {
    const int x = reached_[next];
    auto visit = [&](int y) {
      if (!seen_[y]) {
        seen_[y] = 1;
        parent_[y] = y;
        reached_.push_back(y);
      }
      unite(x, y);
    };
    if (x < slotCount_) {
      const auto& options = part_.slots[x].options;
      for (int k = 0; k < static_cast<int>(options.size()); ++k) {
        if (optionViable(x, k) && !state_.active[options[k].inst]) {
          visit(slotCount_ + options[k].inst);
        }
      }
    } else {
      for (int t : part_.insts[x - slotCount_].slots) {
        if (state_.assigned[t] < 0) visit(t);
      }
    }
  }
  for (int x : reached_) {
    if (x < slotCount_) {
      for (int c : part_.slots[x].clashes) {
        if (seen_[c]) unite(x, c);
      }
    } else {
      for (int e : part_.insts[x - slotCount_].exclusive) {
        if (seen_[slotCount_ + e]) unite(x, slotCount_ + e);
      }
    }
  }
  // Groups by representative, numbered in the order of their first open slot.
  int count = 0;
  for (std::size_t i = 0; i < roots; ++i) {
    const int r = findRoot(reached_[i]);
    if (groupOfRoot_[r] < 0) groupOfRoot_[r] = count++;
  }
  if (count >= 2) {
    groups.resize(count);
    for (int x : reached_) groups[groupOfRoot_[findRoot(x)]].push_back(x);
  }
  for (std::size_t i = 0; i < roots; ++i) groupOfRoot_[findRoot(reached_[i])] = -1;
  for (int x : reached_) seen_[x] = 0;
  return groups;
}

// An AND node: the open slots of `scope` fell into independent groups.
// Each is solved to its optimum on its own, under the scope's limit less
// what the others cost at least; together they fill the scope.
void BranchAndBound::andNode(Scope& scope, std::vector<std::vector<int>>& groups,
                             const std::vector<int>& found) {
  const double g0 = state_.g;
  const int poolSize = pool_.size();
  const int count = static_cast<int>(groups.size());
  std::vector<Scope> parts(count);
  for (int c = 0; c < count; ++c) {
    parts[c].id = nextScope_++;
    for (int x : groups[c]) {
      if (x < slotCount_) {
        slotScope_[x] = parts[c].id;
      } else {
        instScope_[x - slotCount_] = parts[c].id;
      }
    }
  }
  // The node's landmarks whose actions all belong to one group are that
  // group's: every plan of it hits them, and their costs still partition
  // (a landmark across groups is dropped).
  const auto& linkBase = search_.linkBase_;
  auto scopeOf = [&](int a) {
    if (a < instCount_) return instScope_[a];
    const auto s = std::upper_bound(linkBase.begin(), linkBase.end(), a) - linkBase.begin() - 1;
    return slotScope_[s];
  };
  std::vector<std::vector<int>> attributed(count), landmarks(count);
  for (int l : found) {
    const int first = scopeOf(*pool_.begin(l));
    bool one = true;
    for (const int* a = pool_.begin(l); a != pool_.end(l) && one; ++a) one = scopeOf(*a) == first;
    for (int c = 0; c < count && one; ++c) {
      if (parts[c].id == first) attributed[c].push_back(l);
    }
  }
  // Each group's bound: its landmarks and new cuts for what they leave.
  std::vector<double> lower(count);
  double sum = 0;
  for (int c = 0; c < count; ++c) {
    bool complete = false;
    lower[c] = bound(attributed[c], landmarks[c], kInfinity, parts[c].id, &complete);
    sum += lower[c];
  }
  bool useful = g0 + sum < scope.limit - search_.slack_;
  // The smaller groups first: quickly solved, they tighten the others' limits.
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return groups[a].size() < groups[b].size(); });
  for (int c : order) {
    if (!useful) break;
    auto& sub = parts[c];
    sub.limit = scope.limit - (sum - lower[c]);
    sub.start = decisions_.size();
    node(sub, landmarks[c]);
    if (stop_.stopped || !sub.found) {
      useful = false;
      break;
    }
    const double optimum = sub.limit - g0;
    sum += optimum - lower[c];
    lower[c] = optimum;
  }
  if (useful && !stop_.stopped && g0 + sum < scope.limit - search_.slack_) {
    const std::size_t before = decisions_.size();
    for (const auto& sub : parts) {
      for (const auto& [s, k] : sub.best) assign(s, k);
    }
    leaf(scope);
    undoTo(before);
  }
  for (int c = 0; c < count; ++c) {
    for (int x : groups[c]) {
      if (x < slotCount_) {
        slotScope_[x] = scope.id;
      } else {
        instScope_[x - slotCount_] = scope.id;
      }
    }
  }
  pool_.truncate(poolSize);
}

void BranchAndBound::node(Scope& scope, const std::vector<int>& inheritedFromParent) {
  ++nodes_;
  if (stop_.hit()) return;
  const std::size_t decided = decisions_.size();
  Bans bans;
  const int poolSize = pool_.size();
  std::vector<int> landmarks, scratch;
  const std::vector<int>* inherited = &inheritedFromParent;
  int pick = -1;
  auto leave = [&] {
    undoTo(decided);
    lift(bans);
    pool_.truncate(poolSize);
  };
  // Propagate, pick the most constrained open slot, bound; then drop what
  // cannot be part of a better configuration, and when that forces
  // choices, propagate and bound once more (on the same landmarks).
  for (int round = 0;; ++round) {
    const std::size_t assignedBefore = decisions_.size();
    if (!propagate(scope, &pick) || state_.g >= scope.limit - search_.slack_) return leave();
    if (pick < 0) {
      leaf(scope);
      return leave();
    }
    if (round > 0 && decisions_.size() == assignedBefore) break;  // the drops forced nothing
    const double budget = scope.limit - state_.g - search_.slack_;
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
    if (!optionViable(pick, k) || state_.closesCycle(pick, o.inst)) continue;
    // The cheapest by this node's usage costs first, then by estimate.
    const double estimate = o.link + (state_.active[o.inst] ? 0.0 : search_.estimate_[o.inst]);
    ks.push_back({usage_[search_.linkBase_[pick] + k] + 1e-6 * estimate, k});
  }
  std::stable_sort(ks.begin(), ks.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  // When no cycle can form, a configuration in which `pick` takes option k
  // while the producer of an earlier sibling with a link no dearer runs is
  // never better than one of that sibling's (switch the slot to it): such
  // a sibling is skipped when its producer runs already, and its producer
  // is banned in the subtree otherwise.
  std::vector<int> bannedHere;
  for (std::size_t j = 0; j < ks.size(); ++j) {
    const auto& o = slot.options[ks[j].second];
    bool dominated = false;
    bannedHere.clear();
    for (std::size_t i = 0; i < j && search_.dag_ && !dominated; ++i) {
      const auto& earlier = slot.options[ks[i].second];
      if (earlier.link > o.link || earlier.inst == o.inst) continue;
      if (state_.active[earlier.inst]) {
        dominated = true;
      } else {
        ++state_.banned[earlier.inst];
        bannedHere.push_back(earlier.inst);
      }
    }
    if (!dominated && state_.viable(o.inst)) {
      const std::size_t before = decisions_.size();
      assign(pick, ks[j].second);
      node(scope, landmarks);
      undoTo(before);
    }
    for (int i : bannedHere) --state_.banned[i];
    if (stop_.stopped) break;
  }
  leave();
}

PartSolution BranchAndBound::run(PartSolution best) {
  best_ = std::move(best);
  incumbent_ = best_.found ? best_.cost : kInfinity;
  std::vector<int> rootLandmarks;
  bool complete = false;
  // The root's cuts with h^max afresh after each (stronger, and inherited
  // by every node); below, h^max updated from each cut (cheaper).
  const double rootBound = bound({}, rootLandmarks, incumbent_, -1, &complete);
  lmcut_.incremental = true;
  best_.lowerBound = std::min(rootBound, incumbent_);
  if (rootBound == kInfinity) {  // no configuration at all
    best_.optimal = !best_.found;
    best_.found = false;
    return best_;
  }
  // A second start: a dive that follows the root bound's usage costs (the
  // options every cheap configuration can use), polished. It often lands
  // nearer the optimum than the estimate-guided one.
  if (complete) {
    lmcut_.usageCosts(usage_);
    auto guided = search_.polish(search_.dive(limits_, &usage_), limits_);
    if (guided.found && (!best_.found || guided.cost < best_.cost - search_.slack_)) {
      guided.nodes += best_.nodes;
      guided.lowerBound = best_.lowerBound;
      best_ = std::move(guided);
      incumbent_ = best_.cost;
    } else {
      best_.nodes += guided.nodes;
    }
  }
  Scope top;
  top.limit = incumbent_;
  node(top, rootLandmarks);
  best_.nodes += nodes_;
  if (!stop_.stopped) {
    best_.optimal = true;
    best_.lowerBound = best_.found ? best_.cost : kInfinity;
  }
  return std::move(best_);
}

}  // namespace peis::meta::detail
