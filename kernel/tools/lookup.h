// What `peis` commands ask of the ecology before they act: waiting with a
// deadline, finding a PEIS by id or name, the keys a PEIS has, patterns with
// names in them, and the answers to a misspelt name ("did you mean").
#pragma once

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "peis/kernel.h"

namespace peis::cli {

using Clock = std::chrono::steady_clock;

Clock::time_point deadlineIn(double seconds);
std::chrono::milliseconds timeLeft(Clock::time_point deadline);  // at least 1 ms
// Polls `condition` until it holds or the deadline passes.
bool waitUntil(const std::function<bool()>& condition, Clock::time_point deadline);
// Waits for the first other PEIS, then until the membership has not changed
// for 300 ms; never past the deadline.
void settle(Kernel& kernel, Clock::time_point deadline);

bool reachable(const Kernel& kernel, PeisId id);
// The name of PEIS `id` as known here, or "".
std::string nameOf(const Kernel& kernel, PeisId id);
// "7 (lamp)", or "7" when its name is not known.
std::string describePeis(const Kernel& kernel, PeisId id);
// The PEIS `peis ls` lists: every reachable one but this one, and without
// the short-lived tool PEIS (PeerInfo::tool) unless `all`.
std::vector<PeerInfo> listedPeers(const std::vector<PeerInfo>& peers, PeisId self, bool all);

// An id (returned as it is) or a name, which must be reachable by the
// deadline: Error(NotFound) "no PEIS is named 'lmap'; did you mean 'lamp'?"
// naming the closest reachable names; InvalidName, AmbiguousName.
PeisId resolvePeis(Kernel& kernel, const std::string& idOrName, Clock::time_point deadline);

// resolvePeis, then waits until that PEIS is reachable: Error(Unreachable)
// "PEIS 7 is not reachable" at the deadline. For commands that write.
PeisId reachableOwner(Kernel& kernel, const std::string& idOrName, Clock::time_point deadline);

// The keys `owner` lists in its kernel.all-keys (subscribing to it), or
// nothing if that did not arrive by the deadline.
std::optional<std::vector<std::string>> keysOf(Kernel& kernel, PeisId owner,
                                               Clock::time_point deadline);
// "no key 'postion' at PEIS 7 (lamp); did you mean 'position'?" when the
// owner's key list arrived by the deadline and lacks `key`; else nothing.
std::optional<std::string> missingKeyMessage(Kernel& kernel, PeisId owner, const std::string& key,
                                             Clock::time_point deadline);

// "OWNER.KEYPATTERN" with OWNER an id, a name (resolved as resolvePeis) or *.
Pattern patternOf(Kernel& kernel, const std::string& text, Clock::time_point deadline);

// Subscribes to `pattern` and waits until every matching key that each
// reachable PEIS lists in its kernel.all-keys has arrived (and the owner the
// pattern names is reachable). False at the deadline.
bool fetchMatching(Kernel& kernel, const Pattern& pattern, Clock::time_point deadline);

// The words of a space-separated list ("11 12" -> {"11", "12"}).
std::vector<std::string> words(const std::string& text);

}  // namespace peis::cli
