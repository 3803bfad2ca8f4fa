// LM-cut: h^max, a cut between the facts reached from the start and the goal
// zone of the justification graph, the cut's cheapest action cost added to h
// and subtracted from the cut's actions; then h^max again, updated
// incrementally from the cut's actions only (the values can only fall), as in
// Fast Downward's implementation.
#include "planner/lmcut.h"

#include <algorithm>

namespace peis::meta {
namespace {
constexpr double kEpsilon = 1e-9;
}

LmCut::LmCut(const RelaxedTask& task) : task_(task) {
  init_ = task.facts;
  goalFact_ = task.facts + 1;
  const int facts = task.facts + 2;
  const int actions = static_cast<int>(task.actions.size()) + 1;  // + the goal action
  preOf_.assign(facts, {});
  addedBy_.assign(facts, {});
  pre_.resize(actions);
  add_.resize(actions);
  for (int a = 0; a + 1 < actions; ++a) {
    pre_[a] = task.actions[a].pre;
    std::sort(pre_[a].begin(), pre_[a].end());
    pre_[a].erase(std::unique(pre_[a].begin(), pre_[a].end()), pre_[a].end());
    if (pre_[a].empty()) pre_[a].push_back(init_);
    add_[a] = task.actions[a].add;
  }
  add_[actions - 1] = {goalFact_};
  for (int a = 0; a < actions; ++a) {
    for (int f : add_[a]) addedBy_[f].push_back(a);
  }
  for (int a = 0; a + 1 < actions; ++a) {
    for (int f : pre_[a]) preOf_[f].push_back(a);
  }
  pre_[actions - 1] = {init_};
  preOf_[init_].push_back(actions - 1);
  cost_.resize(actions);
  hmax_.resize(facts);
  supporterCost_.resize(actions);
  unsatisfied_.resize(actions);
  pcf_.resize(actions);
  status_.resize(facts);
  toGoal_.resize(facts);
  popped_.resize(facts);
}

void LmCut::setGoal(const std::vector<int>& goal) {
  const int goalAction = static_cast<int>(pre_.size()) - 1;
  // The goal action is the last entry of its preconditions' lists.
  for (int f : pre_[goalAction]) preOf_[f].pop_back();
  pre_[goalAction] = goal;
  std::sort(pre_[goalAction].begin(), pre_[goalAction].end());
  pre_[goalAction].erase(std::unique(pre_[goalAction].begin(), pre_[goalAction].end()),
                         pre_[goalAction].end());
  if (pre_[goalAction].empty()) pre_[goalAction].push_back(init_);
  for (int f : pre_[goalAction]) preOf_[f].push_back(goalAction);
}

void LmCut::push(double value, int fact) {
  queue_.push_back({value, fact});
  std::push_heap(queue_.begin(), queue_.end(), std::greater<>());
}

std::pair<double, int> LmCut::pop() {
  std::pop_heap(queue_.begin(), queue_.end(), std::greater<>());
  const auto top = queue_.back();
  queue_.pop_back();
  return top;
}

void LmCut::computeHmax(const std::vector<char>& isTrue) {
  const int facts = static_cast<int>(hmax_.size());
  const int actions = static_cast<int>(pre_.size());
  std::fill(hmax_.begin(), hmax_.end(), kInfinity);
  for (int a = 0; a < actions; ++a) {
    unsatisfied_[a] = static_cast<int>(pre_[a].size());
    pcf_[a] = -1;
  }
  queue_.clear();
  hmax_[init_] = 0;
  push(0, init_);
  for (int f = 0; f < facts - 2 && !isTrue.empty(); ++f) {
    if (isTrue[f]) {
      hmax_[f] = 0;
      push(0, f);
    }
  }
  while (!queue_.empty()) {
    const auto [h, f] = pop();
    if (h > hmax_[f]) continue;
    popped_[f] = ++pops_;
    for (int a : preOf_[f]) {
      if (--unsatisfied_[a] != 0) continue;
      pcf_[a] = f;  // popped last: a precondition of maximal h^max
      supporterCost_[a] = h;
      if (cost_[a] == kInfinity) continue;
      const double value = h + cost_[a];
      for (int g : add_[a]) {
        if (value < hmax_[g]) {
          hmax_[g] = value;
          push(value, g);
        }
      }
    }
  }
}

// After the costs of `cut` fell: h^max values can only fall, starting from
// the cut's effects; an action whose supporter fell may get a new supporter.
void LmCut::updateHmax(const std::vector<int>& cut) {
  queue_.clear();
  for (int a : cut) {
    const double value = supporterCost_[a] + cost_[a];
    for (int g : add_[a]) {
      if (value < hmax_[g]) {
        hmax_[g] = value;
        push(value, g);
      }
    }
  }
  while (!queue_.empty()) {
    const auto [h, f] = pop();
    if (h > hmax_[f]) continue;
    popped_[f] = ++pops_;
    for (int a : preOf_[f]) {
      if (pcf_[a] != f || supporterCost_[a] <= h) continue;
      // The supporter fell: the precondition of maximal h^max now; among
      // equals the one popped last (what a fresh h^max would choose).
      int best = pre_[a][0];
      for (int p : pre_[a]) {
        if (hmax_[p] > hmax_[best] || (hmax_[p] == hmax_[best] && popped_[p] > popped_[best])) {
          best = p;
        }
      }
      const double old = supporterCost_[a];
      pcf_[a] = best;
      supporterCost_[a] = hmax_[best];
      if (supporterCost_[a] >= old || cost_[a] == kInfinity) continue;
      const double value = supporterCost_[a] + cost_[a];
      for (int g : add_[a]) {
        if (value < hmax_[g]) {
          hmax_[g] = value;
          push(value, g);
        }
      }
    }
  }
}

double LmCut::hmax(const std::vector<double>& costs, const std::vector<char>& isTrue,
                   const std::vector<int>& goal) {
  setGoal(goal);
  const int goalAction = static_cast<int>(pre_.size()) - 1;
  std::copy(costs.begin(), costs.end(), cost_.begin());
  cost_[goalAction] = 0;
  computeHmax(isTrue);
  return hmax_[goalFact_];
}

double LmCut::compute(const std::vector<double>& costs, const std::vector<char>& isTrue,
                      const std::vector<int>& goal, double bound) {
  return compute(costs, isTrue, goal, bound, nullptr);
}

double LmCut::compute(const std::vector<double>& costs, const std::vector<char>& isTrue,
                      const std::vector<int>& goal, double bound,
                      std::vector<Landmark>* landmarks) {
  double h = hmax(costs, isTrue, goal);
  if (h == kInfinity) return kInfinity;
  h = 0;
  const int facts = static_cast<int>(hmax_.size());
  enum : char { kUnseen = 0, kGoalZone = 1, kBeforeZone = 2 };
  while (hmax_[goalFact_] > kEpsilon) {
    // Goal zone: facts from which the goal is reached by zero-cost actions
    // through their supporters.
    std::fill(status_.begin(), status_.end(), kUnseen);
    status_[goalFact_] = kGoalZone;
    stack_.assign(1, goalFact_);
    while (!stack_.empty()) {
      const int f = stack_.back();
      stack_.pop_back();
      for (int a : addedBy_[f]) {
        if (pcf_[a] < 0 || cost_[a] > kEpsilon) continue;
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
      for (int a : preOf_[f]) {
        if (pcf_[a] != f) continue;
        bool inCut = false;
        for (int g : add_[a]) {
          if (status_[g] == kGoalZone) {
            inCut = true;
            break;
          }
        }
        if (inCut) {
          cut_.push_back(a);
          continue;
        }
        for (int g : add_[a]) {
          if (status_[g] == kUnseen) {
            status_[g] = kBeforeZone;
            stack_.push_back(g);
          }
        }
      }
    }
    double cheapest = kInfinity;
    for (int a : cut_) cheapest = std::min(cheapest, cost_[a]);
    if (cut_.empty() || cheapest == kInfinity) break;  // cannot happen on a reachable goal
    h += cheapest;
    if (landmarks) landmarks->push_back({cut_, cheapest});
    if (h >= bound) return h;
    for (int a : cut_) {
      cost_[a] -= cheapest;
      if (cost_[a] < kEpsilon) cost_[a] = 0;
    }
    if (incrementalHmax) {
      updateHmax(cut_);
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
  while (!queue_.empty()) {
    const auto [d, g] = pop();
    if (d > toGoal_[g]) continue;
    for (int b : addedBy_[g]) {
      if (pcf_[b] < 0 || cost_[b] == kInfinity) continue;
      const double value = d + cost_[b];
      for (int f : pre_[b]) {
        if (value < toGoal_[f]) {
          toGoal_[f] = value;
          push(value, f);
        }
      }
    }
  }
  const int actions = static_cast<int>(pre_.size()) - 1;  // without the goal action
  out.resize(actions);
  for (int a = 0; a < actions; ++a) {
    if (pcf_[a] < 0 || cost_[a] == kInfinity) {
      out[a] = kInfinity;
      continue;
    }
    double above = kInfinity;
    for (int g : add_[a]) above = std::min(above, toGoal_[g]);
    out[a] = supporterCost_[a] + cost_[a] + above;
  }
}

}  // namespace peis::meta
