// Link policy: which discovered PEIS to dial and which discovered links to
// close, from the overlay (net/overlay.h), what the routing table knows and
// the heavy flows this PEIS sends or receives (docs/protocol.md §6, "Whom to
// dial"). Pure functions and a pure meter; the Network runs them on its
// timers.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <vector>

#include "peis/types.h"

namespace peis::net {

// A discovered link's minimum life, and how long the membership must have
// been stable, before the link may be pruned.
inline constexpr std::chrono::seconds kLinkGrace{2};

// The overlay peers of `self` that it dials: those with a higher id (of a
// wanted pair only the lower id dials; with `all`, as a tool does, every
// one) it is neither linked to nor dialling. `sortedIds`: the known PEIS and
// `self`, ascending.
std::vector<PeisId> peersToDial(const std::vector<PeisId>& sortedIds, PeisId self,
                                const std::function<bool(PeisId)>& linkedOrDialing,
                                bool all = false);

struct PruneQuestion {
  PeisId peer = 0;
  bool discovered = true;  // false: a --peis-connect link, never pruned
  bool knownByBeacon = true;
  std::chrono::steady_clock::duration age{};  // since the link was established
  bool alternative = false;                   // another linked PEIS advertises a route to peer
  bool peerIsTool = false;                    // a tool's links are never pruned: it is short-lived
  bool busy = false;  // it carried a heavy flow of ours lately (DemandMeter::busy)
};
// Whether `self` closes its link to `question.peer`: it is the lower id, the
// peer is no tool, the overlay no longer wants the pair, the link carries no
// heavy flow of ours, it is old enough and the peer stays reachable through
// another neighbour. Call only once the membership has been stable for
// kLinkGrace.
bool shouldPrune(const std::vector<PeisId>& sortedIds, PeisId self, const PruneQuestion& question);

// --- Demand links -------------------------------------------------------------------
// A heavy flow between this PEIS and one that is not linked to it (its
// frames go through relays) gets a direct link: a relay must never be slowed
// by a flow that is not its own.

struct DemandConfig {
  // A flow of at least this many bytes a second, on average over `window`,
  // is heavy (--peis-demand-link-rate); 0: no demand links.
  std::uint64_t bytesPerSecond = 512u << 10;
  std::chrono::milliseconds window{2000};
  // A link not wanted by the overlay is kept while its flow was heavy
  // within this time, and pruned as the overlay would after.
  std::chrono::milliseconds idleAfter{10000};
  // Demand links (links the overlay does not want) at most, dials included
  // (--peis-max-demand-links).
  std::size_t maxLinks = 4;
};

// The bytes this PEIS sends to (as their source) and receives from (as
// their destination) each other PEIS, in steps; a flow is heavy when its
// last `window` (the steps of one window and the step under way) carried
// DemandConfig::bytesPerSecond on average: window × bytesPerSecond bytes.
// A fast flow is heavy as soon as it has sent that much, not a step later:
// a relay queues what it relays meanwhile.
class DemandMeter {
 public:
  using Time = std::chrono::steady_clock::time_point;
  static constexpr std::size_t kSteps = 4;  // the window, in steps of window / kSteps

  explicit DemandMeter(DemandConfig config) : config_(config) {
    stepLength_.fill(config_.window / kSteps);  // a flow is measured over a whole window
  }
  const DemandConfig& config() const { return config_; }
  // True when these bytes made the flow heavy (it was not before).
  bool add(PeisId peer, std::uint64_t bytes);
  // Ends a step at `now`: what was added since the last step is measured.
  void tick(Time now);
  // Bytes a second over the last window and the step under way (0 for a
  // flow not measured).
  std::uint64_t rate(PeisId peer) const;
  bool heavy(PeisId peer) const { return on() && windowBytes(peer) >= heavyBytes(); }
  // Heavy at a step within idleAfter of `now`.
  bool busy(PeisId peer, Time now) const;
  // The heavy flows' peers, heaviest first (those made heavy by the step
  // under way included).
  std::vector<PeisId> heavyPeers() const;
  // `peer` is gone: forgets its flow.
  void forget(PeisId peer) {
    flows_.erase(peer);
    pending_.erase(peer);
  }
  void clear() {
    flows_.clear();
    pending_.clear();
  }

 private:
  bool on() const { return config_.bytesPerSecond != 0; }
  // The bytes a heavy flow carries in a window.
  std::uint64_t heavyBytes() const;
  std::uint64_t windowBytes(PeisId peer) const;
  struct Flow {
    std::array<std::uint64_t, kSteps> bytes{};
    std::size_t next = 0;   // the slot of the next step
    std::uint64_t sum = 0;  // of `bytes`
    Time lastHeavy{};
    bool everHeavy = false;
  };
  DemandConfig config_;
  std::map<PeisId, Flow> flows_;
  std::map<PeisId, std::uint64_t> pending_;
  Time lastTick_{};
  std::array<std::chrono::steady_clock::duration, kSteps> stepLength_{};
  std::size_t nextStep_ = 0;
};

// What the Network knows of a PEIS with a heavy flow.
struct DemandPeer {
  PeisId id = 0;
  bool linked = false;    // a link to it is established
  bool dialing = false;   // a dial to it is under way
  bool tool = false;      // a tool PEIS: never dialled for
  bool dialable = false;  // discovery knows its address
};
// The PEIS `self` dials for its heavy flows (`heavy`, heaviest first): those
// not linked nor being dialled, no tool, with a known address, as long as
// `demandLinks` (links the overlay does not want, and demand dials under
// way) stays under DemandConfig::maxLinks. A tool dials for nobody.
std::vector<PeisId> demandDials(const std::vector<DemandPeer>& heavy, std::size_t demandLinks,
                                const DemandConfig& config, bool selfIsTool);

}  // namespace peis::net
