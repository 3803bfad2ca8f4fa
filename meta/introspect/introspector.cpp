// Introspection: the subscriptions and callbacks that keep a LiveModel.
#include "introspect/introspector.h"

#include <algorithm>
#include <condition_variable>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "peis/conventions.h"
#include "peis/error.h"

namespace peis::meta {
namespace {

namespace cv = conventions;

bool startsWith(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

bool isMetaInputKey(std::string_view key) { return startsWith(key, cv::kMetaInputPrefix); }

// The keys every PEIS is watched for, whoever owns them.
const std::vector<std::string> kWatched = {special::kAllKeys,
                                           special::kPeers,
                                           std::string(cv::kStatus),
                                           std::string(cv::kCauseNames),
                                           std::string(cv::kComponentName),
                                           std::string(cv::kComponentDescriptor),
                                           "fact.**",
                                           "tiny.bridge",
                                           "config.owned",
                                           "config.lock",
                                           "config.goal.**",
                                           "config.configurator",
                                           cv::launchKey("*", cv::kLaunchPeisName),
                                           cv::launchKey("*", cv::kLaunchDescriptor),
                                           cv::launchKey("*", cv::kLaunchReqState),
                                           cv::launchKey("*", cv::kLaunchCurrState),
                                           cv::launchKey("*", cv::kLaunchStatus)};

// `components.<c>.<field>` of a launcher that introspection follows.
std::optional<std::pair<std::string, std::string>> launchField(std::string_view key) {
  auto parsed = cv::parseLaunchKey(key);
  if (!parsed) return std::nullopt;
  const auto& field = parsed->second;
  if (field == cv::kLaunchPeisName || field == cv::kLaunchDescriptor ||
      field == cv::kLaunchReqState || field == cv::kLaunchCurrState || field == cv::kLaunchStatus)
    return parsed;
  return std::nullopt;
}

std::set<std::string> splitWords(const std::string& text) {
  std::istringstream in(text);
  std::set<std::string> words;
  for (std::string w; in >> w;) words.insert(w);
  return words;
}

}  // namespace

struct Introspector::State {
  Kernel& kernel;
  bool includeTools;
  mutable std::mutex mu;
  std::condition_variable changed;
  std::uint64_t version = 0;
  std::chrono::steady_clock::time_point membershipChanged = std::chrono::steady_clock::now();
  std::function<void()> listener;

  struct Peer {
    LivePeis live;
    bool tool = false;
    bool keysSeen = false;
    std::set<std::string> allKeys;
    std::set<std::string> received;                   // followed keys that have a value here
    std::map<std::string, SubscriptionHandle> exact;  // per-owner subscriptions by key
    std::set<std::string> actuatorKeys;               // `<act>.reqState` … of the descriptor
    std::chrono::steady_clock::time_point goneAt{};   // when it left (if it did)
    std::set<std::string> peersListed;                // its `kernel.peers`: whom it reaches
  };
  // A PEIS gone this long is forgotten (it is kept meanwhile, for explanations).
  static constexpr std::chrono::minutes kForgetAfter{10};
  std::map<PeisId, Peer> peers;
  std::vector<SubscriptionHandle> subscriptions;
  std::vector<CallbackHandle> callbacks;
  TimerHandle timer = 0;

  State(Kernel& k, bool tools) : kernel(k), includeTools(tools) {}

  bool follows(const Peer& peer, const std::string& key) const {
    if (isMetaInputKey(key) || peer.actuatorKeys.count(key)) return true;
    if (key == cv::kStatus || key == cv::kCauseNames || key == cv::kComponentName ||
        key == cv::kComponentDescriptor || key == "tiny.bridge" || key == "config.owned" ||
        key == "config.lock" || key == "config.configurator" || key == special::kPeers)
      return true;
    return startsWith(key, cv::kFactPrefix) || startsWith(key, "config.goal.") ||
           launchField(key).has_value();
  }

  // Called with mu held; returns the listener to call after unlocking.
  std::function<void()> bump() {
    ++version;
    changed.notify_all();
    return listener;
  }

  void subscribeExact(Peer& peer, PeisId owner, const std::string& key) {
    if (peer.exact.count(key) || owner == kernel.id()) return;
    peer.exact[key] = kernel.subscribe(Pattern::exact(owner, key));
  }

  void refreshMembership() {
    std::function<void()> notify;
    // PEIS that joined, came back or restarted: their tuples the kernel
    // holds already are read again below (see replayHeld).
    std::vector<PeisId> arrived;
    {
      std::lock_guard lock(mu);
      std::set<PeisId> present;
      bool changedAny = false;
      for (const auto& info : kernel.peers()) {
        if (info.tool && !includeTools) continue;
        present.insert(info.id);
        auto& peer = peers[info.id];
        const bool restarted =
            peer.live.incarnation != 0 && peer.live.incarnation != std::int64_t(info.incarnation);
        if (!peer.live.alive || peer.live.name != info.name || restarted || peer.live.id == 0) {
          changedAny = true;
        }
        if (!peer.live.alive || restarted || peer.live.id == 0) arrived.push_back(info.id);
        if (restarted) {
          // A new life: its tuples come again (the kernel forgot the old ones).
          peer.keysSeen = false;
          peer.received.clear();
        }
        peer.live.id = info.id;
        peer.live.name = info.name;
        peer.live.alive = true;
        peer.live.incarnation = static_cast<std::int64_t>(info.incarnation);
        peer.tool = info.tool;
      }
      const auto now = std::chrono::steady_clock::now();
      for (auto it = peers.begin(); it != peers.end();) {
        if (!it->second.live.alive && !present.count(it->first) &&
            now - it->second.goneAt > kForgetAfter) {
          it = peers.erase(it);
          changedAny = true;
        } else {
          ++it;
        }
      }
      for (auto& [id, peer] : peers) {
        if (present.count(id) || !peer.live.alive) continue;
        peer.live.alive = false;
        peer.goneAt = now;
        changedAny = true;
        for (const auto& [key, handle] : peer.exact) kernel.unsubscribe(handle);
        peer.exact.clear();
        peer.keysSeen = false;
      }
      if (changedAny) {
        membershipChanged = std::chrono::steady_clock::now();
        notify = bump();
      }
    }
    if (notify) notify();
    for (const PeisId owner : arrived) replayHeld(owner);
  }

  // Hands the tuples of `owner` that the kernel holds now to onTuple. The
  // kernel calls back only on a change: a tuple that came before its owner
  // was a member here (dropped by onTuple), or one held across the owner's
  // brief absence (a route lost and found again under load: the full sync
  // that follows brings the same seqnos, no change, no callback) would
  // otherwise never be seen, and the followed keys of that PEIS with it.
  void replayHeld(PeisId owner) {
    if (owner == kernel.id()) return;  // own tuples: read once at start
    const auto held = kernel.find(Pattern(std::string(special::kAllKeys), owner));
    for (const auto& t : held) onTuple(t, false);  // first: it names the keys to follow
    for (const auto& t : kernel.find(Pattern("**", owner))) {
      if (t.key != special::kAllKeys) onTuple(t, false);
    }
  }

  void onAllKeys(Peer& peer, PeisId owner, const std::string& data) {
    peer.allKeys = splitWords(data);
    peer.keysSeen = true;
    for (const auto& key : peer.allKeys) {
      if (isMetaInputKey(key)) subscribeExact(peer, owner, key);
    }
  }

  void onDescriptor(Peer& peer, PeisId owner, const std::string& data) {
    try {
      peer.live.descriptor =
          Descriptor::fromYaml(data, peer.live.name + "." + std::string(cv::kComponentDescriptor));
      peer.live.descriptorProblem.clear();
    } catch (const Error& e) {
      peer.live.descriptor.reset();
      peer.live.descriptorProblem = e.what();
    }
    peer.actuatorKeys.clear();
    if (!peer.live.descriptor) return;
    for (const auto& f : peer.live.descriptor->functionalities) {
      if (f.activation.empty()) continue;
      for (const auto& key : {cv::reqStateKey(f.activation), cv::currStateKey(f.activation),
                              cv::actuatorStatusKey(f.activation)}) {
        peer.actuatorKeys.insert(key);
        subscribeExact(peer, owner, key);
      }
      peer.live.actuators.try_emplace(f.activation);
    }
  }

  static void onLaunchField(LivePeis& live, const std::string& component, const std::string& field,
                            const std::string& data, bool deleted) {
    auto& e = live.launches[component];
    if (field == cv::kLaunchPeisName) e.peisName = data;
    if (field == cv::kLaunchReqState) e.reqState = data;
    if (field == cv::kLaunchCurrState) e.currState = data;
    if (field == cv::kLaunchStatus) e.status = data;
    if (field == cv::kLaunchDescriptor) {
      e.descriptor.reset();
      e.descriptorProblem.clear();
      if (!deleted && !data.empty()) {
        try {
          e.descriptor =
              Descriptor::fromYaml(data, live.name + "." + cv::launchKey(component, field));
        } catch (const Error& error) {
          e.descriptorProblem = error.what();
        }
      }
    }
    if (deleted && field == cv::kLaunchPeisName) live.launches.erase(component);
  }

  // A tuple changed (`value`) or was deleted (nullptr).
  void onTuple(const Tuple& t, bool deleted) {
    bool known;
    {
      std::lock_guard lock(mu);
      known = peers.count(t.owner) > 0;
    }
    if (!known) refreshMembership();  // its tuples can come before kernel.peers says so
    std::function<void()> notify;
    {
      std::lock_guard lock(mu);
      auto it = peers.find(t.owner);
      // Not a member (yet): membership adds it, then replays what the kernel holds of it.
      if (it == peers.end()) return;
      auto& peer = it->second;
      const std::string& key = t.key;
      if (key == special::kAllKeys) {
        if (deleted) return;
        onAllKeys(peer, t.owner, t.data);
        notify = bump();
      } else {
        if (!follows(peer, key)) return;
        const std::string data = deleted ? std::string() : t.data;
        if (deleted) {
          peer.received.erase(key);
        } else {
          peer.received.insert(key);
        }
        auto& live = peer.live;
        if (key == cv::kStatus) {
          live.status = data;
        } else if (key == cv::kCauseNames) {
          live.causes = data;
        } else if (key == cv::kComponentName) {
          live.component = data;
        } else if (key == cv::kComponentDescriptor) {
          if (deleted) {
            live.descriptor.reset();
            peer.actuatorKeys.clear();
          } else {
            onDescriptor(peer, t.owner, data);
          }
        } else if (key == special::kPeers) {
          peer.peersListed = splitWords(data);
        } else if (key == "tiny.bridge") {
          live.radio = !deleted;
        } else if (key == "config.owned") {
          live.owned = data;
        } else if (key == "config.lock") {
          live.lock = data;
          live.lockSeqno = deleted ? 0 : t.seqno;
        } else if (key == "config.configurator") {
          live.configurator = !deleted && !data.empty();
        } else if (isMetaInputKey(key)) {
          if (deleted) {
            live.links.erase(key);
          } else {
            live.links[key] = data;
          }
        } else if (startsWith(key, "config.goal.")) {
          if (deleted) {
            live.goals.erase(key);
          } else {
            live.goals[key] = data;
          }
        } else if (const auto launch = launchField(key)) {
          onLaunchField(live, launch->first, launch->second, data, deleted);
        } else if (startsWith(key, cv::kFactPrefix)) {
          const auto atom = factOfKey(key);
          if (!atom) return;
          const auto text = atom->toString();
          auto& facts = live.facts;
          facts.erase(std::remove(facts.begin(), facts.end(), text), facts.end());
          if (!deleted && data == cv::kFactTrue) {
            facts.push_back(text);
            std::sort(facts.begin(), facts.end());
          }
        } else if (peer.actuatorKeys.count(key)) {
          const auto dot = key.rfind('.');
          auto& a = live.actuators[key.substr(0, dot)];
          const auto field = key.substr(dot);
          if (field == cv::kReqState) a.reqState = data;
          if (field == cv::kCurrState) a.currState = data;
          if (field == cv::kActuatorStatus) a.status = data;
        }
        notify = bump();
      }
    }
    if (notify) notify();
  }

  // Every alive PEIS's key list and followed keys are here, and no PEIS
  // reaches one that this one does not (a PEIS not heard from yet).
  bool completeLocked() const {
    std::set<std::string> reachable;
    for (const auto& info : kernel.peers()) reachable.insert(std::to_string(info.id));
    for (const auto& [id, peer] : peers) {
      if (!peer.live.alive || (peer.tool && !includeTools)) continue;
      if (id == kernel.id()) continue;
      if (!peer.keysSeen) return false;
      for (const auto& key : peer.allKeys) {
        if (follows(peer, key) && !peer.received.count(key)) return false;
      }
      for (const auto& other : peer.peersListed)
        if (!reachable.count(other)) return false;
    }
    return true;
  }
};

Introspector::Introspector(Kernel& kernel, bool includeTools)
    : state_(std::make_shared<State>(kernel, includeTools)) {
  auto weak = std::weak_ptr<State>(state_);
  auto& s = *state_;
  // Callbacks first, so nothing the subscriptions bring is missed.
  s.callbacks.push_back(kernel.onChange(Pattern(), [weak](const Tuple& t) {
    if (auto state = weak.lock()) state->onTuple(t, false);
  }));
  s.callbacks.push_back(kernel.onDelete(Pattern(), [weak](const Tuple& t) {
    if (auto state = weak.lock()) state->onTuple(t, true);
  }));
  s.callbacks.push_back(
      kernel.onChange(Pattern::exact(kernel.id(), special::kPeers), [weak](const Tuple&) {
        if (auto state = weak.lock()) state->refreshMembership();
      }));
  for (const auto& key : kWatched) s.subscriptions.push_back(kernel.subscribe(Pattern(key)));
  // The routing table can change without kernel.peers text changing (a
  // restart under the same id): look again now and then.
  s.timer = kernel.every(std::chrono::milliseconds(100), [weak] {
    if (auto state = weak.lock()) state->refreshMembership();
  });
  s.refreshMembership();
  // Own tuples that are already there (goals posted before we started).
  for (const auto& key : kWatched) {
    for (const auto& t : kernel.find(Pattern(key, kernel.id()))) s.onTuple(t, false);
  }
}

Introspector::~Introspector() {
  auto& s = *state_;
  s.kernel.cancelTimer(s.timer);
  for (auto h : s.callbacks) s.kernel.removeCallback(h);
  for (auto h : s.subscriptions) s.kernel.unsubscribe(h);
  std::lock_guard lock(s.mu);
  for (auto& [id, peer] : s.peers) {
    for (const auto& [key, handle] : peer.exact) s.kernel.unsubscribe(handle);
  }
  s.listener = nullptr;
}

LiveModel Introspector::snapshot() const {
  std::lock_guard lock(state_->mu);
  LiveModel model;
  for (const auto& [id, peer] : state_->peers) {
    if (peer.tool && !state_->includeTools) continue;
    if (peer.live.id == 0) continue;
    model.peis.push_back(peer.live);
  }
  return model;
}

std::uint64_t Introspector::version() const {
  std::lock_guard lock(state_->mu);
  return state_->version;
}

void Introspector::setListener(std::function<void()> fn) {
  std::lock_guard lock(state_->mu);
  state_->listener = std::move(fn);
}

bool Introspector::complete() const {
  std::lock_guard lock(state_->mu);
  return state_->completeLocked();
}

bool Introspector::waitSettled(std::chrono::milliseconds deadline,
                               std::chrono::milliseconds quiet) {
  const auto until = std::chrono::steady_clock::now() + deadline;
  std::unique_lock lock(state_->mu);
  while (true) {
    const auto now = std::chrono::steady_clock::now();
    const bool stable = now - state_->membershipChanged >= quiet;
    if (stable && state_->completeLocked()) return true;
    if (now >= until) return false;
    // Wake on changes, and at least every 20 ms for the quiet period to pass.
    state_->changed.wait_for(lock, std::chrono::milliseconds(20));
  }
}

}  // namespace peis::meta
