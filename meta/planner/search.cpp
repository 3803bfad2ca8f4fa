// A part's search: its relaxed task and estimates, and the first valid
// configuration by a depth-first dive (see search.h).
#include "planner/search.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <queue>

#include "planner/branch_and_bound.h"
#include "planner/part_state.h"

namespace peis::meta::detail {
namespace {

constexpr double kEpsilon = 1e-9;

// The largest u with every cost an integer multiple of u (a denominator up
// to 1000, a common one up to 10^6), or 0 when there is none.
double costUnit(const std::vector<double>& costs) {
  constexpr double kTolerance = 1e-9;
  auto integral = [&](double x) {
    return std::abs(x - std::round(x)) <= kTolerance * std::max(1.0, std::abs(x));
  };
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

PartSolution PartSearch::first(const SearchLimits& limits) { return dive(limits, nullptr); }

PartSolution PartSearch::dive(const SearchLimits& limits, const std::vector<double>* guide) {
  PartSolution result;
  PartState state(part_);
  state.dag = dag_;
  Stopper stop{limits, &result.nodes};
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
  return BranchAndBound(*this, limits).run(std::move(best));
}

}  // namespace peis::meta::detail
