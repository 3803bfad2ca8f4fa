// Link policy: whom to dial, which links to prune, which heavy flows get a
// demand link; see link_policy.h.
#include "net/link_policy.h"

#include <algorithm>

#include "net/overlay.h"

namespace peis::net {

std::vector<PeisId> peersToDial(const std::vector<PeisId>& sortedIds, PeisId self,
                                const std::function<bool(PeisId)>& linkedOrDialing, bool all) {
  std::vector<PeisId> dial;
  for (const PeisId target : overlayPeers(sortedIds, self)) {
    if ((all || target > self) && !linkedOrDialing(target)) dial.push_back(target);
  }
  return dial;
}

bool shouldPrune(const std::vector<PeisId>& sortedIds, PeisId self, const PruneQuestion& q) {
  if (!q.discovered || q.peerIsTool || self > q.peer || !q.knownByBeacon || q.busy) return false;
  if (q.age < kLinkGrace || overlayWantsSorted(sortedIds, self, q.peer)) return false;
  return q.alternative;  // never cut a PEIS off
}

std::uint64_t DemandMeter::heavyBytes() const {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(config_.window).count();
  return std::max<std::uint64_t>(1, config_.bytesPerSecond * static_cast<std::uint64_t>(ms) / 1000);
}

std::uint64_t DemandMeter::windowBytes(PeisId peer) const {
  std::uint64_t bytes = 0;
  if (const auto it = flows_.find(peer); it != flows_.end()) bytes += it->second.sum;
  if (const auto it = pending_.find(peer); it != pending_.end()) bytes += it->second;
  return bytes;
}

bool DemandMeter::add(PeisId peer, std::uint64_t bytes) {
  if (!on()) return false;
  auto& pending = pending_[peer];
  const auto flow = flows_.find(peer);
  const auto before = pending + (flow == flows_.end() ? 0 : flow->second.sum);
  pending += bytes;
  return before < heavyBytes() && before + bytes >= heavyBytes();
}

void DemandMeter::tick(Time now) {
  if (!on()) return;
  const auto length = lastTick_ == Time{} ? config_.window / kSteps : now - lastTick_;
  lastTick_ = now;
  const std::size_t slot = nextStep_;
  stepLength_[slot] = length;
  nextStep_ = (nextStep_ + 1) % kSteps;
  for (auto& [peer, flow] : flows_) flow.bytes[slot] = 0;  // the step this one replaces
  for (const auto& [peer, bytes] : pending_) flows_[peer].bytes[slot] = bytes;
  pending_.clear();
  for (auto it = flows_.begin(); it != flows_.end();) {
    auto& flow = it->second;
    std::uint64_t sum = 0;
    for (const auto b : flow.bytes) sum += b;
    flow.sum = sum;
    if (sum >= heavyBytes()) {
      flow.lastHeavy = now;
      flow.everHeavy = true;
    }
    // A flow that stopped long ago is forgotten.
    if (sum == 0 && (!flow.everHeavy || now - flow.lastHeavy >= config_.idleAfter)) {
      it = flows_.erase(it);
    } else {
      ++it;
    }
  }
}

std::uint64_t DemandMeter::rate(PeisId peer) const {
  std::chrono::steady_clock::duration window{};
  for (const auto& l : stepLength_) window += l;
  const auto ms = std::max<std::int64_t>(
      1, std::chrono::duration_cast<std::chrono::milliseconds>(window).count());
  return windowBytes(peer) * 1000 / static_cast<std::uint64_t>(ms);
}

bool DemandMeter::busy(PeisId peer, Time now) const {
  if (heavy(peer)) return true;
  const auto it = flows_.find(peer);
  return on() && it != flows_.end() && it->second.everHeavy &&
         now - it->second.lastHeavy < config_.idleAfter;
}

std::vector<PeisId> DemandMeter::heavyPeers() const {
  std::vector<std::pair<std::uint64_t, PeisId>> heavy;
  if (!on()) return {};
  auto consider = [&](PeisId peer) {
    const auto bytes = windowBytes(peer);
    if (bytes >= heavyBytes()) heavy.emplace_back(bytes, peer);
  };
  for (const auto& [peer, flow] : flows_) consider(peer);
  for (const auto& [peer, bytes] : pending_) {
    if (flows_.count(peer) == 0) consider(peer);
  }
  std::sort(heavy.begin(), heavy.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  std::vector<PeisId> result;
  for (const auto& [rate, peer] : heavy) result.push_back(peer);
  return result;
}

std::vector<PeisId> demandDials(const std::vector<DemandPeer>& heavy, std::size_t demandLinks,
                                const DemandConfig& config, bool selfIsTool) {
  std::vector<PeisId> dial;
  if (selfIsTool || config.bytesPerSecond == 0) return dial;
  for (const auto& peer : heavy) {
    if (demandLinks + dial.size() >= config.maxLinks) break;
    if (peer.linked || peer.dialing || peer.tool || !peer.dialable) continue;
    dial.push_back(peer.id);
  }
  return dial;
}

}  // namespace peis::net
