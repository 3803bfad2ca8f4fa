// The planner's answer: which functionality instances run on which PEIS, and
// each link consumer `PEIS.mi-input` <- producer `PEIS.key`, with the total
// cost; whether it is proven optimal (else the lower bound when the deadline
// came); and, when there is no configuration, an explanation naming what is
// missing. Value types only; the deployment turns them into meta tuples and
// activation tuples.
#pragma once

#include <cstdint>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "peis/descriptor.h"
#include "peis/meta/model.h"

namespace peis::meta {

// One functionality instance: a functionality of a component on a PEIS, with
// its variables bound ("?robot" -> "pippi"), sorted by variable name.
struct ActiveInstance {
  std::string peis;  // PEIS name
  int peisId = 0;
  std::string component;
  std::string functionality;
  std::vector<std::pair<std::string, std::string>> binding;
  std::string activation;        // the actuator to switch it on; empty: always on
  double cost = 0;               // its cost as counted in Configuration::cost
  std::string toString() const;  // `pippi/tracker/track{?robot=vac}`
  bool operator==(const ActiveInstance&) const = default;
  auto operator<=>(const ActiveInstance&) const = default;
};

// A subscription: `consumerPeis.consumerKey` (a meta input) points at
// `producerPeis.producerKey`. A goal without a consumer has no link.
struct Link {
  std::string consumerPeis;
  int consumerId = 0;
  std::string consumerKey;  // "mi-position"
  std::string producerPeis;
  int producerId = 0;
  std::string producerKey;  // "position.pippi"
  Term information;         // what flows, e.g. position(pippi)
  LinkKind kind = LinkKind::Lan;
  double cost = 0;
  std::string toString() const;  // `pippi.mi-position <- tracker.position.pippi`
  bool operator==(const Link&) const = default;
  auto operator<=>(const Link& other) const {
    return std::tie(consumerPeis, consumerKey, producerPeis, producerKey) <=>
           std::tie(other.consumerPeis, other.consumerKey, other.producerPeis, other.producerKey);
  }
};

struct Configuration {
  std::vector<ActiveInstance> instances;  // sorted
  std::vector<Link> links;                // sorted
  double cost = 0;                        // sum of instance and link costs
  bool operator==(const Configuration&) const = default;
};

enum class PlanStatus {
  Optimal,     // proven cheapest
  Feasible,    // valid, not proven optimal (the deadline or the node limit came first)
  Infeasible,  // no configuration exists (explanation says why)
  Unknown,     // the deadline came before any configuration was found
};
const char* toString(PlanStatus status);

struct PlanStats {
  std::int64_t groundInstances = 0;    // functionality instances after grounding
  std::int64_t relevantInstances = 0;  // of those, the ones that can serve a goal
  std::int64_t parts = 0;              // independent sub-problems
  std::int64_t nodes = 0;              // search nodes expanded and local-search moves tried
  double firstSolutionMs = 0;          // time to the first valid configuration
  double totalMs = 0;
};

struct PlanResult {
  PlanStatus status = PlanStatus::Unknown;
  Configuration configuration;  // valid when status is Optimal or Feasible
  double lowerBound = 0;        // no configuration is cheaper than this
  // Why there is no configuration (Infeasible), one finding per line, e.g.
  // "no producer of position(vac): tracker/track on PEIS cam-server needs
  // image(?c) from two cameras, camera/capture on PEIS cam2 is dead".
  std::vector<std::string> explanation;
  PlanStats stats;

  bool ok() const { return status == PlanStatus::Optimal || status == PlanStatus::Feasible; }
  // (cost - lowerBound) / cost; 0 when proven optimal.
  double gap() const;
};

}  // namespace peis::meta
