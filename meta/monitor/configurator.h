// The configurator: the long-running meta-level PEIS. On its own thread it
//
//  - keeps the live model (Introspector) and publishes it: `model.live`
//    (LiveModel YAML) and `model.yaml` (a model file `peis config plan
//    --model` reads);
//  - collects the goal tuples `config.goal.*` of every alive PEIS (and its
//    own), plans the cheapest configuration for all of them together and
//    deploys it (Deployer), answering each goal tuple in `config.goal-status`;
//  - watches the deployed configuration (HealthMonitor): on a failure it
//    marks the failed instance (ConfigurationPlanner::setFailed), plans
//    again with the deployed configuration as warm start and deploys the
//    repair, with no person involved; a deployment refused by a PEIS is
//    planned again without it; what another writer changed is put back
//    (drift);
//  - when a failed part is healthy again, or the ecology changed, switches
//    only to a configuration cheaper by the margin (no flapping);
//  - plans also with the components that a launcher (peis-init) declares but
//    does not run: before it deploys a configuration that uses one, it asks
//    that launcher to start it (`<launcher>.components.<c>.reqState` = `on`),
//    waits until its PEIS has joined, and plans again with it; a component
//    it started is stopped (`reqState` = `off`) once no deployed
//    configuration uses it;
//  - records every step as an event tuple `config.event.<n>`.
//
// Several configurators may run: the oldest (by start time, then id) that
// is alive is active, the others stand by (`config.configurator` says which)
// and take over when it goes. docs/configuration.md, "The configurator".
#pragma once

#include <chrono>
#include <memory>
#include <vector>

#include "deploy/deployer.h"
#include "peis/kernel.h"
#include "peis/meta/model.h"

namespace peis::meta {

struct ConfiguratorOptions {
  // Zero means: derived from the kernel's liveness period L.
  std::chrono::milliseconds grace{0};           // stale input judged after this (L)
  std::chrono::milliseconds settle{0};          // a new deployment's links get this long (L)
  std::chrono::milliseconds recoverHold{0};     // a failed part must look healthy this long (2 L)
  std::chrono::milliseconds startupWait{0};     // wait for the ecology before planning (2 L)
  std::chrono::milliseconds retryAfter{30000};  // first retry of a part that did not deliver
  std::chrono::milliseconds driftHold{250};     // a changed deployed tuple is put back after this
  std::chrono::milliseconds planTimeLimit{200};
  std::chrono::milliseconds launchWait{30000};  // a launched component's PEIS must join in this
  double switchMargin = 0.2;  // switch to a cheaper configuration only if >= 20 % cheaper
  std::size_t eventsKept = 256;
  LinkCosts costs;
  std::vector<LinkCostOverride> overrides;
  DeployOptions deploy;
};

class Configurator {
 public:
  // Starts at once (its thread, the introspection, the published tuples).
  Configurator(Kernel& kernel, ConfiguratorOptions options = {});
  ~Configurator();  // stops the thread; the ecology keeps the configuration
  Configurator(const Configurator&) = delete;
  Configurator& operator=(const Configurator&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::meta
