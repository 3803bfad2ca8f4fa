// LM-cut: h^max, a cut between the facts reached from the start and the goal
// zone of the justification graph, the cut's cheapest action cost added to h
// and subtracted from the cut's actions; then h^max again (afresh, or
// updated from the cut only), until the goal costs nothing more. The
// supporter of an action (its precondition of maximal h^max) is, among
// equals, the one reached last, free actions being expanded at once (depth
// first): on configuration problems that gives markedly stronger bounds
// than the first (docs/configuration.md, "How the planner works").
#include "planner/lmcut.h"

#include <algorithm>

namespace peis::meta {
namespace {

constexpr double kEpsilon = 1e-9;

// Compressed rows from per-row lists.
void flatten(const std::vector<std::vector<int>>& rows, std::vector<int>& start,
             std::vector<int>& items) {
  start.assign(1, 0);
  items.clear();
  for (const auto& row : rows) {
    items.insert(items.end(), row.begin(), row.end());
    start.push_back(static_cast<int>(items.size()));
  }
}

}  // namespace

void LmCut::Landmarks::truncate(int n) {
  if (n >= size()) return;
  cost.resize(n);
  start.resize(n + 1);
  actions.resize(start[n]);
}

LmCut::LmCut(const RelaxedTask& task) {
  init_ = task.facts;
  goalFact_ = task.facts + 1;
  const int facts = task.facts + 2;
  goalAction_ = static_cast<int>(task.actions.size());
  const int actions = goalAction_ + 1;
  std::vector<std::vector<int>> pre(actions), add(actions), uses(facts), adders(facts);
  for (int a = 0; a < goalAction_; ++a) {
    pre[a] = task.actions[a].pre;
    std::sort(pre[a].begin(), pre[a].end());
    pre[a].erase(std::unique(pre[a].begin(), pre[a].end()), pre[a].end());
    if (pre[a].empty()) pre[a].push_back(init_);
    add[a] = task.actions[a].add;
    for (int f : pre[a]) uses[f].push_back(a);
    for (int f : add[a]) adders[f].push_back(a);
  }
  add[goalAction_] = {goalFact_};
  adders[goalFact_].push_back(goalAction_);
  flatten(pre, preStart_, pre_);
  flatten(add, addStart_, add_);
  flatten(uses, useStart_, use_);
  flatten(adders, adderStart_, adder_);
  isGoal_.assign(facts, 0);
  cost_.resize(actions);
  supporterCost_.resize(actions);
  unsatisfied_.resize(actions);
  pcf_.resize(actions);
  hmax_.resize(facts);
  status_.resize(facts);
  popped_.assign(facts, 0);
  toGoal_.resize(facts);
}

void LmCut::setGoal(const std::vector<int>& goal) {
  for (int f : goal_) isGoal_[f] = 0;
  goal_ = goal;
  std::sort(goal_.begin(), goal_.end());
  goal_.erase(std::unique(goal_.begin(), goal_.end()), goal_.end());
  if (goal_.empty()) goal_.push_back(init_);
  for (int f : goal_) isGoal_[f] = 1;
}

template <typename F>
void LmCut::forEachUse(int fact, F&& f) const {
  for (int i = useStart_[fact]; i < useStart_[fact + 1]; ++i) f(use_[i]);
  if (isGoal_[fact]) f(goalAction_);
}

void LmCut::push(double value, int fact) {
  queue_.push_back({value, fact});
  // Sift up.
  std::size_t i = queue_.size() - 1;
  const Entry e = queue_[i];
  while (i > 0) {
    const std::size_t parent = (i - 1) / 2;
    if (!(e < queue_[parent])) break;
    queue_[i] = queue_[parent];
    i = parent;
  }
  queue_[i] = e;
}

LmCut::Entry LmCut::pop() {
  const Entry top = queue_[0];
  const Entry last = queue_.back();
  queue_.pop_back();
  const std::size_t n = queue_.size();
  if (n > 0) {
    // Sift the last entry down from the root.
    std::size_t i = 0;
    while (true) {
      std::size_t child = 2 * i + 1;
      if (child >= n) break;
      if (child + 1 < n && queue_[child + 1] < queue_[child]) ++child;
      if (!(queue_[child] < last)) break;
      queue_[i] = queue_[child];
      i = child;
    }
    queue_[i] = last;
  }
  return top;
}

void LmCut::computeHmax(const std::vector<char>& isTrue) {
  const int facts = static_cast<int>(hmax_.size());
  const int actions = goalAction_ + 1;
  std::fill(hmax_.begin(), hmax_.end(), kInfinity);
  for (int a = 0; a < goalAction_; ++a) {
    unsatisfied_[a] = preStart_[a + 1] - preStart_[a];
    pcf_[a] = -1;
  }
  unsatisfied_[goalAction_] = static_cast<int>(goal_.size());
  pcf_[goalAction_] = -1;
  (void)actions;
  queue_.clear();
  level_.clear();
  // The start: init and the true facts, at 0, expanded in index order.
  hmax_[init_] = 0;
  for (int f = facts - 3; f >= 0 && !isTrue.empty(); --f) {
    if (isTrue[f]) {
      hmax_[f] = 0;
      level_.push_back(f);
    }
  }
  level_.push_back(init_);
  // Facts reached by a free action at the value being expanded need no
  // heap: they are expanded next, from `level_` (last in, first out).
  while (!level_.empty() || !queue_.empty()) {
    double h;
    int f;
    if (!level_.empty()) {
      f = level_.back();
      level_.pop_back();
      h = hmax_[f];
    } else {
      const Entry e = pop();
      if (e.value > hmax_[e.fact]) continue;
      h = e.value;
      f = e.fact;
    }
    popped_[f] = ++pops_;
    forEachUse(f, [&](int a) {
      // Facts come in order of h^max: the last precondition is a maximal one.
      if (--unsatisfied_[a] != 0) return;
      pcf_[a] = f;
      supporterCost_[a] = h;
      const double c = cost_[a];
      if (c == kInfinity) return;
      const double value = h + c;
      for (int i = addStart_[a]; i < addStart_[a + 1]; ++i) {
        const int g = add_[i];
        if (value < hmax_[g]) {
          hmax_[g] = value;
          if (c == 0) {
            level_.push_back(g);
          } else {
            push(value, g);
          }
        }
      }
    });
  }
}

// After the costs of the cut fell: h^max values can only fall, starting from
// the cut's effects; an action whose supporter fell takes the precondition
// of maximal h^max now (among equals the one reached last).
void LmCut::updateHmax() {
  queue_.clear();
  for (int a : cut_) {
    const double value = supporterCost_[a] + cost_[a];
    for (int i = addStart_[a]; i < addStart_[a + 1]; ++i) {
      const int g = add_[i];
      if (value < hmax_[g]) {
        hmax_[g] = value;
        push(value, g);
      }
    }
  }
  while (!queue_.empty()) {
    const Entry e = pop();
    if (e.value > hmax_[e.fact]) continue;
    const double h = e.value;
    const int f = e.fact;
    popped_[f] = ++pops_;
    forEachUse(f, [&](int a) {
      if (pcf_[a] != f || unsatisfied_[a] != 0 || supporterCost_[a] <= h) return;
      int best = -1;
      auto consider = [&](int p) {
        if (best < 0 || hmax_[p] > hmax_[best] ||
            (hmax_[p] == hmax_[best] && popped_[p] > popped_[best])) {
          best = p;
        }
      };
      if (a == goalAction_) {
        for (int p : goal_) consider(p);
      } else {
        for (int i = preStart_[a]; i < preStart_[a + 1]; ++i) consider(pre_[i]);
      }
      const double old = supporterCost_[a];
      pcf_[a] = best;
      supporterCost_[a] = hmax_[best];
      if (supporterCost_[a] >= old || cost_[a] == kInfinity) return;
      const double value = supporterCost_[a] + cost_[a];
      for (int i = addStart_[a]; i < addStart_[a + 1]; ++i) {
        const int g = add_[i];
        if (value < hmax_[g]) {
          hmax_[g] = value;
          push(value, g);
        }
      }
    });
  }
}

double LmCut::hmax(const std::vector<double>& costs, const std::vector<char>& isTrue,
                   const std::vector<int>& goal) {
  setGoal(goal);
  std::copy(costs.begin(), costs.end(), cost_.begin());
  cost_[goalAction_] = 0;
  computeHmax(isTrue);
  return hmax_[goalFact_];
}

double LmCut::compute(const std::vector<double>& costs, const std::vector<char>& isTrue,
                      const std::vector<int>& goal, double bound) {
  return compute(costs, isTrue, goal, bound, nullptr, nullptr);
}

double LmCut::compute(const std::vector<double>& costs, const std::vector<char>& isTrue,
                      const std::vector<int>& goal, double bound, Landmarks* landmarks,
                      std::vector<int>* found) {
  double h = hmax(costs, isTrue, goal);
  if (h == kInfinity) return kInfinity;
  h = 0;
  const int facts = static_cast<int>(hmax_.size());
  enum : char { kUnseen = 0, kGoalZone = 1, kBeforeZone = 2 };
  while (hmax_[goalFact_] > kEpsilon) {
    // Goal zone: facts from which the goal is reached by free actions
    // through their supporters.
    std::fill(status_.begin(), status_.end(), kUnseen);
    status_[goalFact_] = kGoalZone;
    stack_.assign(1, goalFact_);
    while (!stack_.empty()) {
      const int f = stack_.back();
      stack_.pop_back();
      for (int i = adderStart_[f]; i < adderStart_[f + 1]; ++i) {
        const int a = adder_[i];
        if (unsatisfied_[a] != 0 || cost_[a] > kEpsilon) continue;
        const int p = pcf_[a];
        if (status_[p] == kUnseen) {
          status_[p] = kGoalZone;
          stack_.push_back(p);
        }
      }
    }
    // Facts reached from the start without entering the zone; the cut is
    // the actions from them (through their supporters) into the zone.
    cut_.clear();
    stack_.clear();
    if (status_[init_] == kUnseen) {
      status_[init_] = kBeforeZone;
      stack_.push_back(init_);
    }
    for (int f = 0; f < facts - 2 && !isTrue.empty(); ++f) {
      if (isTrue[f] && status_[f] == kUnseen) {
        status_[f] = kBeforeZone;
        stack_.push_back(f);
      }
    }
    while (!stack_.empty()) {
      const int f = stack_.back();
      stack_.pop_back();
      forEachUse(f, [&](int a) {
        if (pcf_[a] != f || unsatisfied_[a] != 0) return;
        for (int i = addStart_[a]; i < addStart_[a + 1]; ++i) {
          if (status_[add_[i]] == kGoalZone) {
            cut_.push_back(a);
            return;
          }
        }
        for (int i = addStart_[a]; i < addStart_[a + 1]; ++i) {
          const int g = add_[i];
          if (status_[g] == kUnseen) {
            status_[g] = kBeforeZone;
            stack_.push_back(g);
          }
        }
      });
    }
    double cheapest = kInfinity;
    for (int a : cut_) cheapest = std::min(cheapest, cost_[a]);
    if (cut_.empty() || cheapest == kInfinity) break;  // cannot happen on a reachable goal
    h += cheapest;
    if (landmarks) {
      found->push_back(landmarks->size());
      landmarks->actions.insert(landmarks->actions.end(), cut_.begin(), cut_.end());
      landmarks->start.push_back(static_cast<int>(landmarks->actions.size()));
      landmarks->cost.push_back(cheapest);
    }
    if (h >= bound) return h;
    for (int a : cut_) {
      cost_[a] -= cheapest;
      if (cost_[a] < kEpsilon) cost_[a] = 0;
    }
    if (incremental) {
      updateHmax();
    } else {
      computeHmax(isTrue);
    }
  }
  return h;
}

void LmCut::usageCosts(std::vector<double>& out) {
  // The cheapest residual chain from each fact to the goal: an action that
  // has the fact as a precondition, then one of its effects, and so on.
  std::fill(toGoal_.begin(), toGoal_.end(), kInfinity);
  queue_.clear();
  toGoal_[goalFact_] = 0;
  push(0, goalFact_);
  auto relax = [&](int b, double d) {
    if (unsatisfied_[b] != 0 || cost_[b] == kInfinity) return;
    const double value = d + cost_[b];
    auto lower = [&](int f) {
      if (value < toGoal_[f]) {
        toGoal_[f] = value;
        push(value, f);
      }
    };
    if (b == goalAction_) {
      for (int f : goal_) lower(f);
    } else {
      for (int i = preStart_[b]; i < preStart_[b + 1]; ++i) lower(pre_[i]);
    }
  };
  while (!queue_.empty()) {
    const Entry e = pop();
    if (e.value > toGoal_[e.fact]) continue;
    for (int i = adderStart_[e.fact]; i < adderStart_[e.fact + 1]; ++i) relax(adder_[i], e.value);
  }
  out.resize(goalAction_);
  for (int a = 0; a < goalAction_; ++a) {
    if (unsatisfied_[a] != 0 || cost_[a] == kInfinity) {
      out[a] = kInfinity;
      continue;
    }
    double above = kInfinity;
    for (int i = addStart_[a]; i < addStart_[a + 1]; ++i) above = std::min(above, toGoal_[add_[i]]);
    out[a] = supporterCost_[a] + cost_[a] + above;
  }
}

}  // namespace peis::meta
