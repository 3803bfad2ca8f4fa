// LM-cut: repeated h^max, a cut between the facts reached from the start and
// the goal zone of the justification graph, the cut's cheapest action cost
// added to h and subtracted from the cut's actions.
#include "planner/lmcut.h"

#include <algorithm>
#include <queue>

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
  unsatisfied_.resize(actions);
  pcf_.resize(actions);
  inZone_.resize(facts);
  reached_.resize(facts);
}

void LmCut::computeHmax(const std::vector<char>& isTrue) {
  const int facts = static_cast<int>(hmax_.size());
  const int actions = static_cast<int>(pre_.size());
  std::fill(hmax_.begin(), hmax_.end(), kInfinity);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (int a = 0; a < actions; ++a) {
    unsatisfied_[a] = static_cast<int>(pre_[a].size());
    pcf_[a] = -1;
  }
  hmax_[init_] = 0;
  queue.push({0, init_});
  for (int f = 0; f < facts - 2 && !isTrue.empty(); ++f) {
    if (isTrue[f]) {
      hmax_[f] = 0;
      queue.push({0, f});
    }
  }
  while (!queue.empty()) {
    const auto [h, f] = queue.top();
    queue.pop();
    if (h > hmax_[f]) continue;
    for (int a : preOf_[f]) {
      if (--unsatisfied_[a] != 0 || cost_[a] == kInfinity) continue;
      pcf_[a] = f;  // popped last: a precondition of maximal h^max
      const double value = h + cost_[a];
      for (int g : add_[a]) {
        if (value < hmax_[g]) {
          hmax_[g] = value;
          queue.push({value, g});
        }
      }
    }
  }
}

double LmCut::hmax(const std::vector<double>& costs, const std::vector<char>& isTrue,
                   const std::vector<int>& goal) {
  const int goalAction = static_cast<int>(pre_.size()) - 1;
  // The goal action is the last entry of its preconditions' lists.
  for (int f : pre_[goalAction]) preOf_[f].pop_back();
  pre_[goalAction] = goal.empty() ? std::vector<int>{init_} : goal;
  for (int f : pre_[goalAction]) preOf_[f].push_back(goalAction);
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
  const int goalAction = static_cast<int>(pre_.size()) - 1;
  double h = hmax(costs, isTrue, goal);
  if (h == kInfinity) return kInfinity;
  h = 0;
  const int facts = static_cast<int>(hmax_.size());
  std::vector<int> stack, cut;
  // Actions grouped by their precondition choice, rebuilt per round.
  std::vector<std::vector<int>> byPcf(facts);
  while (hmax_[goalFact_] > kEpsilon) {
    // Goal zone: facts from which the goal is reached by zero-cost actions.
    std::fill(inZone_.begin(), inZone_.end(), 0);
    inZone_[goalFact_] = 1;
    stack.assign(1, goalFact_);
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int a : addedBy_[f]) {
        if (pcf_[a] < 0 || cost_[a] > kEpsilon) continue;
        const int p = pcf_[a];
        if (!inZone_[p]) {
          inZone_[p] = 1;
          stack.push_back(p);
        }
      }
    }
    // Facts reached from the start without entering the zone; the cut.
    for (auto& list : byPcf) list.clear();
    for (int a = 0; a <= goalAction; ++a) {
      if (pcf_[a] >= 0) byPcf[pcf_[a]].push_back(a);
    }
    std::fill(reached_.begin(), reached_.end(), 0);
    cut.clear();
    reached_[init_] = 1;
    stack.assign(1, init_);
    for (int f = 0; f < facts - 2 && !isTrue.empty(); ++f) {
      if (isTrue[f] && !inZone_[f]) {
        reached_[f] = 1;
        stack.push_back(f);
      }
    }
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int a : byPcf[f]) {
        bool inCut = false;
        for (int g : add_[a]) {
          if (inZone_[g]) {
            inCut = true;
          } else if (!reached_[g]) {
            reached_[g] = 1;
            stack.push_back(g);
          }
        }
        if (inCut) cut.push_back(a);
      }
    }
    std::sort(cut.begin(), cut.end());
    cut.erase(std::unique(cut.begin(), cut.end()), cut.end());
    double cheapest = kInfinity;
    for (int a : cut) cheapest = std::min(cheapest, cost_[a]);
    if (cut.empty() || cheapest == kInfinity) break;  // cannot happen on a reachable goal
    h += cheapest;
    if (landmarks) landmarks->push_back({cut, cheapest});
    if (h >= bound) return h;
    for (int a : cut) {
      cost_[a] -= cheapest;
      if (cost_[a] < kEpsilon) cost_[a] = 0;
    }
    computeHmax(isTrue);
  }
  return h;
}

}  // namespace peis::meta
