// Kernel::waitForPeer: waiting until a named PEIS is reachable, written on
// the Kernel's own public calls (peers(), onKernelThread()) so that it needs
// nothing of the kernel's inside.
#include <algorithm>
#include <thread>

#include "peis/kernel.h"

namespace peis {
namespace {

// The ids of the reachable PEIS that `idOrName` names: the id itself, or
// every PEIS that carries the name.
std::vector<PeisId> reachableNamed(const std::vector<PeerInfo>& peers, std::optional<PeisId> id,
                                   std::string_view name) {
  std::vector<PeisId> ids;
  for (const auto& peer : peers) {
    if (id ? peer.id == *id : peer.name == name) ids.push_back(peer.id);
  }
  return ids;
}

}  // namespace

std::optional<PeisId> Kernel::waitForPeer(std::string_view idOrName,
                                          std::chrono::milliseconds timeout) const {
  const auto id = parsePeisId(idOrName);
  if (!id) validateName(idOrName);
  if (timeout.count() > 0 && onKernelThread()) {
    throw Error(ErrorCode::WouldDeadlock,
                "waitForPeer with a timeout on the kernel thread would block it");
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  // Membership changes arrive with the kernel's topology events; a short
  // poll of the snapshot sees them without a hook into the kernel thread.
  auto pause = std::chrono::milliseconds(1);
  while (true) {
    const auto ids = reachableNamed(peers(), id, idOrName);
    if (ids.size() == 1) return ids.front();
    if (ids.size() > 1) {
      std::string list;
      for (auto each : ids) list += (list.empty() ? "" : ", ") + std::to_string(each);
      throw Error(ErrorCode::AmbiguousName, "the name '" + std::string(idOrName) +
                                                "' is carried by the reachable PEIS " + list +
                                                "; use an id instead");
    }
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) return std::nullopt;
    std::this_thread::sleep_for(
        std::min<std::chrono::steady_clock::duration>(pause, deadline - now));
    pause = std::min(pause * 2, std::chrono::milliseconds(20));
  }
}

}  // namespace peis
