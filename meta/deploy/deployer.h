// Deployment: makes the ecology hold a configuration, with ordinary remote
// writes, consistently when several deployers run at once or one dies
// half-way (docs/configuration.md, "Deployment"):
//
//   1. Every PEIS the new configuration writes on, or that holds a record
//      (`config.owned`) of an earlier one, is locked in ascending id order:
//      a line `<generation> <deployer> deploying` appended to its
//      `config.lock` with compare-and-set (`append … ifSeqno`). A lock held
//      by a live deployer is waited for; one held by a PEIS that is gone is
//      taken over (compare-and-set again, so only one taker wins). Ordered
//      locking cannot deadlock.
//   2. With all locks held, the diff is taken against the values there now.
//      Each touched PEIS first gets the union of its old and new keys as its
//      record (so a deployer killed from here on leaves records naming every
//      key it may have written), then all writes go out in parallel, then
//      the record becomes the new keys alone, and the locks are released
//      (`done`, compare-and-set).
//   3. A write of the new configuration refused or not answered (the PEIS
//      is dead, refuses, times out) undoes the writes that succeeded and
//      the records, releases the locks and fails naming the PEIS, so no half
//      configuration is left. A PEIS that does not take a switch-off (a key
//      only the old configuration wanted) is left as it is, with a warning:
//      one such PEIS cannot block every later configuration. Likewise a PEIS
//      locked only because it holds a record of an earlier configuration,
//      that does not take the lock (hung), is left out with a warning.
//
// Blocking: call it from a thread of its own, never the kernel thread. The
// cache it reads (locks, records, current values) is kept by an
// Introspector on the same Kernel, which must exist.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "deploy/deployment_diff.h"
#include "introspect/live_model.h"
#include "peis/kernel.h"
#include "peis/meta/configuration.h"

namespace peis::meta {

struct DeployOptions {
  // How long to wait for a lock that a live deployer holds.
  std::chrono::milliseconds lockWait{5000};
};

struct DeployResult {
  bool ok = false;
  bool unchanged = false;        // nothing to write: no lock taken, nothing touched
  std::uint64_t generation = 0;  // of this deployment
  std::size_t writes = 0;        // tuples written (switching off included)
  std::size_t peisTouched = 0;
  std::string error;                  // when !ok: what failed, naming the PEIS
  std::vector<std::string> warnings;  // switch-offs a PEIS did not take (given up)
  int failedPeis = 0;                 // the PEIS that refused or did not answer (0: none)
  std::string failedPeisName;
  double milliseconds = 0;
};

class Deployer {
 public:
  explicit Deployer(Kernel& kernel, DeployOptions options = {});

  // Deploys `configuration` (ids as the live model has them). `live` is a
  // recent snapshot: names, who is alive, the records. PEIS in `leaveAlone`
  // (ones whose functionality just failed) are not locked or written unless
  // the configuration itself needs them: what they hold of an earlier
  // configuration stays until a later deployment.
  DeployResult deploy(const Configuration& configuration, const LiveModel& live,
                      const std::set<int>& leaveAlone = {});

  // The changes deploying would make now, without locks (for the
  // idempotency check, drift and `--dry-run`); `leaveAlone` as for deploy.
  std::vector<PeisChanges> pendingChanges(const Configuration& configuration, const LiveModel& live,
                                          const std::set<int>& leaveAlone = {}) const;

 private:
  struct Held {
    int peis;
    std::uint64_t seqno;
  };
  bool acquire(int peis, const std::string& name, std::uint64_t generation, Held& held,
               std::string& error);
  void release(const std::vector<Held>& held, std::uint64_t generation);
  std::uint64_t nextGeneration(const LiveModel& live) const;
  std::map<int, std::set<std::string>> ownedRecords(const LiveModel& live) const;
  std::vector<PeisChanges> changesExcept(const Configuration& configuration, const LiveModel& live,
                                         const std::set<int>& excluded) const;
  // Of `leaveAlone`, the PEIS the configuration does not write on.
  static std::set<int> leftAlone(const Configuration& configuration,
                                 const std::set<int>& leaveAlone);
  std::optional<std::string> currentValue(int peis, const std::string& key) const;
  bool alive(int peis) const;

  Kernel& kernel_;
  DeployOptions options_;
};

}  // namespace peis::meta
