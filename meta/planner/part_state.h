// The state of a search over one part: which instances run, the option
// each slot takes, which slots are required and which instances may not be
// activated; assignments applied and undone in stack order; the cycle
// check. And the search's node and time limits. Internal to the planner.
#pragma once

#include <chrono>
#include <cstdint>
#include <vector>

#include "planner/search.h"

namespace peis::meta::detail {

struct PartState {
  const Part& part;
  std::vector<char> active;
  std::vector<int> assigned;  // option per slot, -1 none
  std::vector<int> required;  // how many active users (or the goal) need it
  std::vector<int> banned;    // reasons an instance may not be activated
  double g = 0;
  std::vector<int> mark, seen;  // for the cycle check
  int epoch = 0;
  bool dag = false;  // no cycle is possible at all: skip the check

  explicit PartState(const Part& p)
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

// Counts nodes against the node limit and checks the deadline (every 16
// nodes); once hit, stays hit.
struct Stopper {
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

}  // namespace peis::meta::detail
