// Finding PEIS, keys and patterns for the `peis` commands; see lookup.h.
#include "lookup.h"

#include <algorithm>
#include <sstream>
#include <thread>

#include "args.h"
#include "suggest.h"

namespace peis::cli {

using namespace std::chrono_literals;

Clock::time_point deadlineIn(double seconds) {
  return Clock::now() + std::chrono::microseconds(static_cast<long long>(seconds * 1e6));
}

std::chrono::milliseconds timeLeft(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return std::max(left, 1ms);
}

bool waitUntil(const std::function<bool()>& condition, Clock::time_point deadline) {
  while (!condition()) {
    if (Clock::now() >= deadline) return condition();
    std::this_thread::sleep_for(2ms);
  }
  return true;
}

void settle(Kernel& kernel, Clock::time_point deadline) {
  while (kernel.peers().size() < 2 && Clock::now() < deadline) std::this_thread::sleep_for(5ms);
  auto last = kernel.peers().size();
  auto stableSince = Clock::now();
  while (Clock::now() < deadline && Clock::now() - stableSince < 300ms) {
    std::this_thread::sleep_for(10ms);
    const auto now = kernel.peers().size();
    if (now != last) {
      last = now;
      stableSince = Clock::now();
    }
  }
}

bool reachable(const Kernel& kernel, PeisId id) {
  const auto peers = kernel.peers();
  return std::any_of(peers.begin(), peers.end(), [&](const PeerInfo& p) { return p.id == id; });
}

std::string nameOf(const Kernel& kernel, PeisId id) {
  for (const auto& peer : kernel.peers()) {
    if (peer.id == id && !peer.name.empty()) return peer.name;
  }
  auto name = kernel.get(id, special::kName);
  return name ? name->data : std::string();
}

std::string describePeis(const Kernel& kernel, PeisId id) {
  const auto name = nameOf(kernel, id);
  return std::to_string(id) + (name.empty() ? "" : " (" + name + ")");
}

std::vector<PeerInfo> listedPeers(const std::vector<PeerInfo>& peers, PeisId self, bool all) {
  std::vector<PeerInfo> listed;
  for (const auto& peer : peers) {
    if (peer.id != self && (all || !peer.tool)) listed.push_back(peer);
  }
  return listed;
}

PeisId resolvePeis(Kernel& kernel, const std::string& idOrName, Clock::time_point deadline) {
  if (auto id = parsePeisId(idOrName)) return *id;
  if (auto id = kernel.waitForPeer(idOrName, timeLeft(deadline))) return *id;
  std::vector<std::string> names;
  for (const auto& peer : kernel.peers()) {
    if (peer.id != kernel.id()) names.push_back(peer.name);
  }
  throw Error(ErrorCode::NotFound,
              "no PEIS is named '" + idOrName + "'" + didYouMean(closestNames(idOrName, names)));
}

PeisId reachableOwner(Kernel& kernel, const std::string& idOrName, Clock::time_point deadline) {
  const auto owner = resolvePeis(kernel, idOrName, deadline);
  if (!waitUntil([&] { return reachable(kernel, owner); }, deadline)) {
    throw Error(ErrorCode::Unreachable, "PEIS " + std::to_string(owner) + " is not reachable");
  }
  return owner;
}

std::optional<std::vector<std::string>> keysOf(Kernel& kernel, PeisId owner,
                                               Clock::time_point deadline) {
  std::optional<Tuple> list;
  if (owner == kernel.id()) {
    list = kernel.get(special::kAllKeys);
  } else {
    list = kernel.get(owner, special::kAllKeys, timeLeft(deadline));
  }
  if (!list) return std::nullopt;
  return words(list->data);
}

std::optional<std::string> missingKeyMessage(Kernel& kernel, PeisId owner, const std::string& key,
                                             Clock::time_point deadline) {
  const auto keys = keysOf(kernel, owner, deadline);
  if (!keys || std::find(keys->begin(), keys->end(), key) != keys->end()) return std::nullopt;
  return "no key '" + key + "' at PEIS " + describePeis(kernel, owner) +
         didYouMean(closestNames(key, *keys));
}

Pattern patternOf(Kernel& kernel, const std::string& text, Clock::time_point deadline) {
  const auto dot = text.find('.');
  if (dot == std::string::npos) throw UsageError("'" + text + "' is not OWNER.KEYPATTERN");
  const auto owner = text.substr(0, dot);
  if (owner == "*") return Pattern(text.substr(dot + 1));
  return Pattern(text.substr(dot + 1), resolvePeis(kernel, owner, deadline));
}

bool fetchMatching(Kernel& kernel, const Pattern& pattern, Clock::time_point deadline) {
  kernel.subscribe(pattern);
  kernel.subscribe(Pattern(special::kAllKeys));
  auto complete = [&] {
    if (pattern.ownerFilter() && !reachable(kernel, *pattern.ownerFilter())) return false;
    for (const auto& peer : kernel.peers()) {
      if (peer.id == kernel.id() || (pattern.ownerFilter() && *pattern.ownerFilter() != peer.id)) {
        continue;
      }
      auto keys = kernel.get(peer.id, special::kAllKeys);
      if (!keys) return false;
      for (const auto& key : words(keys->data)) {
        if (key != special::kAllKeys && pattern.matchesOwnerAndKey(peer.id, key) &&
            !kernel.get(peer.id, key)) {
          return false;
        }
      }
    }
    return true;
  };
  return waitUntil(complete, deadline);
}

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> result;
  for (std::string word; in >> word;) result.push_back(word);
  return result;
}

}  // namespace peis::cli
