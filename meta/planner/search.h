// The search over one independent part of a ground problem: which producer
// fills each required meta input. A greedy dive gives a valid configuration
// first, local search polishes it (local_search.cpp), branch and bound
// (branch_and_bound.h) proves the optimum or stops at the limits with a
// lower bound. Internal to the planner.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

#include "planner/lmcut.h"

namespace peis::meta::detail {

// Local indices; `global` maps back to the GroundProblem.
struct Part {
  struct Inst {
    int global = 0;
    double cost = 0;
    std::vector<int> slots;      // distinct, local
    std::vector<int> exclusive;  // local
    bool warm = false;           // used by the warm-start configuration
  };
  struct Option {
    int inst = 0;  // local
    double link = 0;
  };
  struct Slot {
    int global = 0;
    std::vector<Option> options;
    std::vector<int> clashes;  // local
    std::vector<int> users;    // local instances that need it
    bool goal = false;
    int warmOption = -1;  // the option the warm start used
  };
  std::vector<Inst> insts;
  std::vector<Slot> slots;
};

struct PartSolution {
  bool found = false;
  bool optimal = false;
  double cost = 0;
  double lowerBound = 0;
  std::vector<int> chosen;  // per slot: option index, or -1 when not required
  std::vector<char> active;
  std::int64_t nodes = 0;
};

struct SearchLimits {
  std::optional<std::chrono::steady_clock::time_point> deadline;
  std::int64_t nodeLimit = 0;
};

class PartSearch {
 public:
  explicit PartSearch(const Part& part);
  // A valid configuration fast (greedy dive with backtracking); found=false
  // when none exists or the limits came first.
  PartSolution first(const SearchLimits& limits);
  // A cheaper valid configuration near `start` by local moves
  // (local_search.cpp); `start` itself when none is found or it is !found.
  PartSolution polish(PartSolution start, const SearchLimits& limits);
  // Improves `incumbent` (which may be !found) to the optimum within limits.
  PartSolution improve(PartSolution incumbent, const SearchLimits& limits);

 private:
  friend class BranchAndBound;
  // A depth-first dive with backtracking; options by estimate, or by
  // `guide` (a value per link action of task_) when given.
  PartSolution dive(const SearchLimits& limits, const std::vector<double>* guide);
  const Part& part_;
  RelaxedTask task_;
  std::vector<int> linkBase_;     // first link action of each slot
  std::vector<double> estimate_;  // h_add of each instance, for option order
  bool dag_ = false;              // no cycle of producers can form
  double slack_ = 0;              // how much cheaper a better configuration is at least
};

}  // namespace peis::meta::detail
