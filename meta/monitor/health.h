// Execution monitoring, as pure decisions (no kernel; the time is given), so
// each rule is unit-tested on its own (docs/configuration.md, "Monitoring
// and repair"):
//
//  - HealthMonitor looks at the deployed configuration in a LiveModel and
//    names the functionality instances that failed: the PEIS running one is
//    gone; its component says `error`; a consumer has been `waiting` on an
//    input the configuration feeds for at least the grace period (the
//    liveness period by default, so a component frozen for less than that is
//    never taken for failed) while its producer claims to run — the producer
//    is blamed, not a producer that is itself waiting on its own inputs; a
//    precondition of an instance no longer holds. Each failure is reported
//    once per deployment.
//  - FailedParts keeps what failed and says when it may be used again: a
//    gone PEIS when it is back, an error when it cleared, an instance that
//    did not deliver when its PEIS restarted or, failing that, after a retry
//    period that doubles each time the same part fails again; in all cases
//    only after it stayed healthy for a hold time.
//  - worthSwitching: a working configuration is replaced by a cheaper one
//    only when that is cheaper by the margin (no flapping).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "introspect/live_model.h"
#include "peis/meta/configuration.h"
#include "peis/meta/model.h"

namespace peis::meta {

using MonitorClock = std::chrono::steady_clock;

enum class FailureKind { PeisGone, ComponentError, StaleInput, PreconditionLost };
const char* toString(FailureKind kind);

struct Failure {
  FailureKind kind = FailureKind::PeisGone;
  InstanceSelector instance;  // the failed instance, with its binding
  int peisId = 0;
  std::int64_t incarnation = 0;  // of its PEIS when it failed (0: unknown)
  std::string cause;             // for a person
  bool operator==(const Failure&) const = default;
};

struct MonitorPolicy {
  // How long a consumer must wait on an input before its producer is blamed.
  std::chrono::milliseconds grace{2000};
  // How long links of a new deployment get to deliver before being judged.
  std::chrono::milliseconds settle{2000};
};

// The selector naming exactly one active instance (its binding included).
InstanceSelector selectorOf(const ActiveInstance& instance);

// The active instances of `configuration` that write `link.producerKey` on
// the link's producer PEIS (by their descriptors in `model`).
std::vector<ActiveInstance> producersOf(const Configuration& configuration, const Model& model,
                                        const Link& link);

class HealthMonitor {
 public:
  explicit HealthMonitor(MonitorPolicy policy = {});
  // A configuration was deployed at `now`, planned on `model`.
  void deployed(Configuration configuration, Model model, MonitorClock::time_point now);
  void clear();
  bool active() const { return active_; }
  const Configuration& configuration() const { return configuration_; }
  const Model& model() const { return model_; }

  // The failures visible now that were not reported before.
  std::vector<Failure> observe(const LiveModel& live, MonitorClock::time_point now);
  // When observe() must look again even if nothing changes (a grace or
  // settle period ends); nothing when no evidence is pending.
  std::optional<MonitorClock::time_point> nextCheck() const;

 private:
  MonitorPolicy policy_;
  bool active_ = false;
  Configuration configuration_;
  Model model_;
  MonitorClock::time_point deployedAt_{};
  std::map<std::pair<int, std::string>, MonitorClock::time_point> waitingSince_;
  std::set<std::string> reported_;
};

struct FailedPart {
  Failure failure;
  MonitorClock::time_point since{};
  std::chrono::milliseconds retryAfter{0};  // StaleInput: when to try it again anyway
  std::optional<MonitorClock::time_point> healthySince;
};

class FailedParts {
 public:
  // `hold`: how long a part must look healthy before it is used again;
  // `retryAfter`: the first retry period of a part that did not deliver.
  FailedParts(std::chrono::milliseconds hold, std::chrono::milliseconds retryAfter);
  // Records a failure (PreconditionLost is not a failed part: the facts
  // changed, the planner sees that). Returns false when it was known.
  bool add(const Failure& failure, MonitorClock::time_point now);
  // The parts that are healthy again (and no longer failed) as of `now`.
  std::vector<Failure> recovered(const LiveModel& live, MonitorClock::time_point now);
  std::vector<InstanceSelector> selectors() const;
  std::optional<MonitorClock::time_point> nextCheck() const;
  bool empty() const { return parts_.empty(); }

 private:
  std::chrono::milliseconds hold_, retryAfter_;
  std::map<std::string, FailedPart> parts_;
  std::map<std::string, std::chrono::milliseconds> backoff_;  // per part, across failures
};

// True when `candidate` is cheaper than `current` by at least the margin:
// candidate <= (1 - margin) * current.
bool worthSwitching(double currentCost, double candidateCost, double margin);

}  // namespace peis::meta
