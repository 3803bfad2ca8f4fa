// The tinybridge's core: one I/O thread that owns every piece of bridge
// state (nodes, served subscriptions, pending writes); the kernels' threads
// only hand it work through post() (see tiny_bridge.h for the model).
#include "tiny_bridge.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <tuple>
#include <vector>

#include "key_mapping.h"
#include "key_registry.h"
#include "node_descriptors.h"
#include "peis/component.h"
#include "peis/error.h"
#include "peis/key.h"
#include "peis/log.h"
#include "peis/pattern.h"
#include "radio_link.h"
#include "radio_security.h"
#include "tiny_timing.h"
#include "tiny_tuple.h"

namespace peis::bridge {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr milliseconds kTick{100};
constexpr milliseconds kBeaconEvery{TINY_BEACON_INTERVAL_MS};
constexpr milliseconds kNodeSubscribeEvery{TINY_RESUB_INTERVAL_MS};
// A tiny subscriber that stops renewing is forgotten, as a tiny owner would.
constexpr milliseconds kServedTimeout{TINY_SUBSCRIBER_TIMEOUT_MS};

std::uint32_t msOf(Timestamp t) {
  return t == kNoTime ? 0u
                      : static_cast<std::uint32_t>(
                            std::chrono::duration_cast<milliseconds>(t.time_since_epoch()).count());
}

// A full tuple's ts_expire as a tiny lifetime: ms from now (computed in ms,
// so no stamp overflows), 0 ("never") when further off than the u32 field
// holds (49.7 days), -1 when it has passed.
long long tinyLifetime(Timestamp expire) {
  using std::chrono::duration_cast;
  const auto left = duration_cast<milliseconds>(expire.time_since_epoch()).count() -
                    duration_cast<milliseconds>(systemNow().time_since_epoch()).count();
  return left <= 0 ? -1 : left > 0xFFFFFFFFLL ? 0 : left;
}

std::vector<std::uint16_t> subKeys(const tiny_key& key) {
  return std::vector<std::uint16_t>(key.sub, key.sub + key.len);
}

std::string dataOf(const tiny_tuple& t) {
  const auto* p = tiny_tuple_data(&t);
  return std::string(reinterpret_cast<const char*>(p), t.data_len);
}

bool seqNewer(std::uint32_t a, std::uint32_t b) {
  const std::uint32_t d = a - b;
  return d != 0 && d < 0x80000000u;
}

}  // namespace

struct TinyBridge::Impl {
  BridgeConfig config;
  KeyRegistry registry;
  RegistrySeed seed;
  NodeDescriptors descriptors;
  std::unique_ptr<RadioLink> link;
  Kernel kernel;
  Clock::time_point started = Clock::now();

  // Work handed over by other threads; runs on the I/O thread.
  std::mutex inboxMu;
  std::vector<std::function<void()>> inbox;
  int wake[2] = {-1, -1};
  std::atomic<bool> stopping{false};

  // --- I/O thread only -------------------------------------------------------
  struct Node {
    std::uint16_t id = 0;
    std::unique_ptr<Kernel> proxy;
    // The node's descriptor published on its proxy (destroyed before the proxy).
    std::unique_ptr<Component> component;
    Clock::time_point lastHeard, lastSubscribe;
    std::uint32_t uptimeMs = 0;
    std::map<std::vector<std::uint16_t>, std::uint32_t> mirroredSeqno;  // by tiny key
  };
  std::map<std::uint16_t, Node> nodes;

  // A tiny node's subscription to full PEIS tuples, served by its proxy.
  using ServedKey =
      std::tuple<std::uint16_t, std::uint16_t, std::uint8_t, std::vector<std::uint16_t>>;
  struct Served {
    std::uint16_t subscriber = 0;
    Pattern pattern;
    SubscriptionHandle subscription = 0;
    CallbackHandle callback = 0;
    Clock::time_point lastRenew;
  };
  std::map<ServedKey, Served> served;
  // Tiny seqnos of forwarded full tuples: a full owner's seqno restarts with
  // its incarnation, so the bridge numbers what it forwards itself, starting
  // from its clock (a restarted bridge continues above what nodes cached).
  struct Forwarded {
    std::uint64_t fullSeqno = 0;
    Timestamp tsWrite = kNoTime;
    std::uint32_t tinySeqno = 0;
  };
  std::map<TupleRef, Forwarded> forwarded;
  std::uint32_t forwardCounter = msOf(systemNow());

  struct PendingWrite {
    std::uint16_t node = 0;
    tiny_tuple request{};
    WriteDecision decide;
    Clock::time_point deadline, lastSent;
    int sends = 0;
  };
  std::vector<PendingWrite> pending;

  std::unique_ptr<RadioSecurity> security;  // a secured radio; null: open
  std::set<std::uint16_t> refusedNodes;     // told once in the log
  std::uint16_t frameSeq = 0;
  Clock::time_point lastBeacon;
  BridgeStats counters;
  std::string publishedNodes = "-";
  mutable std::mutex statsMu;
  BridgeStats statsSnapshot;

  static Options bridgeOptions(const BridgeConfig& config) {
    auto options = config.peis;
    if (options.name.empty()) options.name = "tinybridge";
    return options;
  }

  explicit Impl(BridgeConfig c)
      : config(std::move(c)),
        registry(config.registryPath),
        seed(config.seedPath.empty() ? RegistrySeed{} : loadRegistrySeed(config.seedPath)),
        descriptors(config.seedPath.empty() ? NodeDescriptors{}
                                            : loadNodeDescriptors(config.seedPath)),
        link((registry.applySeed(seed), openRadioLink(config.link))),
        kernel(bridgeOptions(config)) {
    if (config.tinyId == TINY_ID_NONE || config.tinyId == TINY_ID_BROADCAST)
      throw Error(ErrorCode::InvalidArgument, "the bridge's tiny id must be 1..65534");
    if (::pipe2(wake, O_CLOEXEC | O_NONBLOCK) != 0)
      throw Error(ErrorCode::InvalidArgument, "cannot create the bridge's wake pipe");
    if (!config.radioKeysPath.empty()) {
      security = std::make_unique<RadioSecurity>(
          loadRadioKeys(config.radioKeysPath), [this] { return registry.radioCounter(); },
          [this](std::uint32_t value) { registry.setRadioCounter(value); });
      kernel.set("tinybridge.radio", "secured");
    } else {
      kernel.set("tinybridge.radio", "open");
    }
    kernel.set("tinybridge.link", link->describe());
    kernel.set("tinybridge.tiny-id", std::to_string(config.tinyId));
    kernel.set("tinybridge.nodes", "");
    for (const auto& [name, index] : registry.entries()) publishKey(name, index);
    log::info(kernel.id(), "tinybridge: on " + link->describe() + " as tiny node " +
                               std::to_string(config.tinyId) + ", key registry " + registry.path() +
                               " with " + std::to_string(registry.entries().size()) + " keys");
  }

  ~Impl() {
    for (auto& write : pending) write.decide(Error(ErrorCode::Stopped, "the tinybridge stopped"));
    pending.clear();
    served.clear();
    nodes.clear();  // proxies leave the ecology
    for (int fd : wake)
      if (fd >= 0) ::close(fd);
  }

  // --- hand-over from other threads ---------------------------------------------
  void post(std::function<void()> fn) {
    {
      std::lock_guard lock(inboxMu);
      inbox.push_back(std::move(fn));
    }
    const char byte = 1;
    (void)!::write(wake[1], &byte, 1);
  }

  void runInbox() {
    std::vector<std::function<void()>> work;
    {
      std::lock_guard lock(inboxMu);
      work.swap(inbox);
    }
    for (auto& fn : work) fn();
  }

  // --- radio output ---------------------------------------------------------------
  // `buf` has room for TINY_FRAME_MAX bytes: a secured radio seals in place.
  void sendFrame(std::uint8_t* buf, std::size_t n) {
    if (n == 0) return;
    if (security && !security->seal(buf, n)) return;
    if (link->send(Frame(buf, buf + n))) ++counters.framesOut;
  }

  void sendBeacon(Clock::time_point now) {
    std::uint8_t buf[TINY_FRAME_MAX];
    const auto uptime = std::chrono::duration_cast<milliseconds>(now - started).count();
    sendFrame(buf, tiny_encode_beacon_frame(
                       buf, config.tinyId, frameSeq++, 0,
                       static_cast<std::uint8_t>(std::min<std::size_t>(nodes.size(), 255)),
                       static_cast<std::uint32_t>(uptime)));
    lastBeacon = now;
  }

  // Keeps the bridge subscribed to every key of a node.
  void subscribeToNode(Node& node, Clock::time_point now) {
    std::uint8_t buf[TINY_FRAME_MAX];
    tiny_key all{};
    sendFrame(buf, tiny_encode_sub_frame(buf, TINY_FRAME_SUBSCRIBE, config.tinyId, node.id,
                                         frameSeq++, node.id, TINY_SUB_PREFIX, &all));
    node.lastSubscribe = now;
  }

  // --- the bridge's own tuples ---------------------------------------------------
  void publishKey(const std::string& name, KeyIndex index) {
    kernel.set("tinybridge.keys." + name, std::to_string(index));
  }

  void publishNodes() {
    std::string list;
    for (const auto& [id, node] : nodes) list += (list.empty() ? "" : " ") + std::to_string(id);
    if (list == publishedNodes) return;
    publishedNodes = list;
    kernel.set("tinybridge.nodes", list);
  }

  void publishStats() {
    std::lock_guard lock(statsMu);
    statsSnapshot = counters;
  }

  // --- nodes ------------------------------------------------------------------------
  std::string nodeName(std::uint16_t id) const {
    auto it = seed.nodeNames.find(id);
    return it != seed.nodeNames.end() ? it->second : "tiny-" + std::to_string(id);
  }

  // Whether the bridge makes a proxy PEIS for node `id` (why not, if not).
  std::optional<std::string> proxyRefusal(std::uint16_t id) {
    // A node id that a full PEIS of the ecology holds already.
    for (const auto& peer : kernel.peers()) {
      if (peer.id == id && !nodes.count(id)) {
        return "PEIS " + std::to_string(id) + " '" + peer.name + "' holds that id";
      }
    }
    if (security) {
      if (!security->knows(id)) return "the bridge holds no radio key for it";
    } else if (!seed.nodeNames.count(id)) {
      std::size_t unregistered = 0;
      for (const auto& [known, node] : nodes) unregistered += seed.nodeNames.count(known) ? 0 : 1;
      if (unregistered >= config.maxUnregisteredNodes) {
        return std::to_string(unregistered) +
               " nodes the seed does not name have proxies already (--max-unregistered-nodes)";
      }
    }
    return std::nullopt;
  }

  Node* nodeHeard(std::uint16_t id, Clock::time_point now) {
    if (id == config.tinyId) return nullptr;
    auto it = nodes.find(id);
    if (it == nodes.end()) {
      if (auto why = proxyRefusal(id)) {
        ++counters.nodesRefused;
        if (refusedNodes.insert(id).second && refusedNodes.size() <= 64) {
          log::warn(kernel.id(),
                    "tinybridge: no proxy for tiny node " + std::to_string(id) + ": " + *why);
        }
        return nullptr;
      }
      Node node;
      node.id = id;
      auto options = config.peis;
      options.id = id;
      options.name = nodeName(id);
      options.port = 0;
      options.setTuples.clear();
      if (options.network && kernel.port() != 0)
        options.connect.push_back("127.0.0.1:" + std::to_string(kernel.port()));
      try {
        node.proxy = std::make_unique<Kernel>(options);
      } catch (const std::exception& e) {
        log::error(kernel.id(), "tinybridge: no proxy PEIS for tiny node " + std::to_string(id) +
                                    ": " + e.what());
        return nullptr;
      }
      node.proxy->set("tiny.bridge", std::to_string(kernel.id()));
      node.proxy->set("tiny.link", link->describe());
      if (auto d = descriptors.find(id); d != descriptors.end()) publishDescriptor(node, d->second);
      node.proxy->setWriteGate(
          [this, id](const Tuple& t, PeisId writer, const WriteDecision& decide) {
            if (t.key.rfind("kernel.", 0) == 0) return false;  // the proxy's own
            if (t.key.rfind("tiny.", 0) == 0) {
              decide(Error(ErrorCode::Refused, "tiny.* tuples are kept by the tinybridge"));
              return true;
            }
            post([this, id, t, writer, decide] { onProxyWrite(id, t, writer, decide); });
            return true;
          });
      log::info(kernel.id(), "tinybridge: tiny node " + std::to_string(id) + " joined as PEIS '" +
                                 options.name + "'");
      ++counters.nodesJoined;
      it = nodes.emplace(id, std::move(node)).first;
      subscribeToNode(it->second, now);
      publishNodes();
    }
    it->second.lastHeard = now;
    return &it->second;
  }

  // The node's functionality descriptor, as a component publishes it, so
  // the meta-level can plan with the node (status `running` while it is heard).
  void publishDescriptor(Node& node, const Descriptor& descriptor) {
    try {
      node.component = std::make_unique<Component>(*node.proxy, descriptor.component, descriptor);
      for (const auto& f : descriptor.functionalities) {
        for (const auto& port : f.outputs) {
          const auto key = port.outputKey();
          if (key.find('?') == std::string::npos && !keyProblem(key)) {
            try {
              node.component->output(key);
            } catch (const Error&) {
              // declared by another functionality already
            }
          }
        }
      }
      node.component->start();
    } catch (const Error& e) {
      log::warn(kernel.id(), "tinybridge: the descriptor of tiny node " + std::to_string(node.id) +
                                 " was not published: " + e.what());
    }
  }

  void dropNode(std::uint16_t id, const std::string& why) {
    auto it = nodes.find(id);
    if (it == nodes.end()) return;
    for (auto p = pending.begin(); p != pending.end();) {
      if (p->node == id) {
        p->decide(Error(ErrorCode::Unreachable, "tiny node " + std::to_string(id) + " " + why));
        ++counters.writesFailed;
        p = pending.erase(p);
      } else {
        ++p;
      }
    }
    for (auto s = served.begin(); s != served.end();)
      s = s->second.subscriber == id ? served.erase(s) : std::next(s);
    log::info(kernel.id(), "tinybridge: tiny node " + std::to_string(id) + " left (" + why + ")");
    nodes.erase(it);  // the proxy leaves the ecology
    ++counters.nodesLeft;
    publishNodes();
  }

  // --- radio input ------------------------------------------------------------------
  void onFrame(const Frame& bytes, Clock::time_point now) {
    tiny_frame f;
    tiny_stats decodeStats{};
    ++counters.framesIn;
    std::size_t length = bytes.size();
    if (security) {
      if (length >= TINY_FRAME_HEADER_SIZE &&
          (bytes[TINY_FOFF_SRC] | bytes[TINY_FOFF_SRC + 1] << 8) == config.tinyId) {
        return;  // our own, heard back
      }
      std::string why;
      if (!security->open(bytes.data(), length, &why)) {
        ++counters.framesRefused;
        const auto src =
            length >= TINY_FRAME_HEADER_SIZE
                ? static_cast<std::uint16_t>(bytes[TINY_FOFF_SRC] | bytes[TINY_FOFF_SRC + 1] << 8)
                : std::uint16_t{0};
        if (refusedNodes.insert(src).second && refusedNodes.size() <= 64) {
          log::warn(kernel.id(), "tinybridge: dropped a frame from tiny node " +
                                     std::to_string(src) + ": " + why);
        }
        return;
      }
    }
    if (tiny_decode_frame(bytes.data(), length, &f, &decodeStats) != TINY_DECODE_OK) {
      ++counters.framesDropped;
      return;
    }
    if (f.src == config.tinyId) return;
    // Another base station's beacon is not a tiny node.
    if (f.type == TINY_FRAME_BEACON && !(f.beacon_flags & TINY_BEACON_TINY)) return;
    Node* node = nodeHeard(f.src, now);
    if (node == nullptr) return;
    switch (f.type) {
      case TINY_FRAME_BEACON:
        if (f.beacon_uptime_ms + TINY_BEACON_INTERVAL_MS < node->uptimeMs) {
          log::info(kernel.id(), "tinybridge: tiny node " + std::to_string(f.src) + " restarted");
          node->mirroredSeqno.clear();
          subscribeToNode(*node, now);
        }
        node->uptimeMs = f.beacon_uptime_ms;
        break;
      case TINY_FRAME_TUPLE:
        // The bridge listens to every tuple on the air; it mirrors those of
        // the nodes (not the ones it forwarded itself, src == tinyId). A
        // node speaks for its own tuples only: another's is forged.
        if (f.tuple.owner != f.src) {
          ++counters.tuplesForged;
          break;
        }
        mirror(*node, f.tuple);
        break;
      case TINY_FRAME_SUBSCRIBE:
      case TINY_FRAME_UNSUBSCRIBE:
        onTinySubscribe(f, now);
        break;
      default:  // WRITE frames between nodes: their owner answers
        break;
    }
  }

  // A node's tuple (heard on the radio) into its proxy.
  void mirror(Node& node, const tiny_tuple& t) {
    tiny_key key;
    tiny_tuple_key(&t, &key);
    const auto sub = subKeys(key);
    auto seen = node.mirroredSeqno.find(sub);
    if (seen != node.mirroredSeqno.end() && !seqNewer(t.seqno, seen->second)) {
      ++counters.tuplesStale;
      return;
    }
    node.mirroredSeqno[sub] = t.seqno;
    const auto data = dataOf(t);
    ++counters.tuplesMirrored;
    // A confirmation of held writes: the newest write of this key with this
    // value, and any older ones of the same key (overwritten since).
    auto sameKey = [&](const PendingWrite& p) {
      tiny_key pk;
      tiny_tuple_key(&p.request, &pk);
      return p.node == node.id && tiny_key_equal(&pk, &key);
    };
    std::optional<std::size_t> confirmed;
    for (std::size_t i = 0; i < pending.size(); ++i) {
      if (sameKey(pending[i]) && dataOf(pending[i].request) == data &&
          pending[i].request.creator == t.creator)
        confirmed = i;
    }
    if (confirmed) {
      std::vector<PendingWrite> keep;
      for (std::size_t i = 0; i < pending.size(); ++i) {
        if (i <= *confirmed && sameKey(pending[i])) {
          pending[i].decide(std::nullopt);  // applied by the proxy's kernel, in order
          ++counters.writesConfirmed;
        } else {
          keep.push_back(std::move(pending[i]));
        }
      }
      pending.swap(keep);
      return;
    }
    WriteOptions options;
    options.ts_user = t.ts_user != 0 ? Timestamp(milliseconds(t.ts_user)) : kNoTime;
    options.ttl = milliseconds(t.ts_expire);
    auto* proxy = node.proxy.get();
    // Through the proxy's thread, so it lands in order with decided writes.
    proxy->post([proxy, fullKey = fullKeyOf(registry, key), data, options] {
      try {
        proxy->set(fullKey, data, options);
      } catch (const std::exception& e) {
        log::warn(proxy->id(),
                  std::string("tinybridge: cannot mirror ") + fullKey + ": " + e.what());
      }
    });
  }

  // A full PEIS's set of a tiny node's tuple, held by the proxy's gate.
  void onProxyWrite(std::uint16_t id, const Tuple& t, PeisId writer, const WriteDecision& decide) {
    const auto now = Clock::now();
    if (!nodes.count(id)) {
      ++counters.writesRefused;
      decide(Error(ErrorCode::Unreachable, "tiny node " + std::to_string(id) + " is not heard"));
      return;
    }
    // Key parts that get an index now are published once it is given.
    std::vector<std::string> fresh;
    for (const auto part : splitKey(t.key))
      if (!part.empty() && part[0] != '#' && !registry.find(part)) fresh.emplace_back(part);
    std::string why;
    std::optional<tiny_key> key;
    try {
      key = tinyKeyOf(registry, t.key, true, &why);
    } catch (const Error& e) {
      why = e.what();
    }
    for (const auto& name : fresh) {
      const auto index = registry.find(name);
      if (!index) continue;  // the mapping failed: nothing was interned
      publishKey(name, *index);
      ++counters.keysAdded;
      log::info(kernel.id(), "tinybridge: key '" + name + "' is tiny index " +
                                 std::to_string(*index) + " from now on");
    }
    if (!key) {
      ++counters.writesRefused;
      decide(Error(ErrorCode::InvalidKey, "no tiny key for '" + t.key + "': " + why));
      return;
    }
    PendingWrite write;
    write.node = id;
    write.request.owner = id;
    write.request.creator =
        writer >= 1 && writer <= 0xFFFE ? static_cast<std::uint16_t>(writer) : config.tinyId;
    write.request.ts_user = msOf(t.ts_user);
    if (t.ts_expire != kNoTime) {
      const auto left = tinyLifetime(t.ts_expire);
      write.request.ts_expire = left == 0 ? 0u : static_cast<std::uint32_t>(std::max(left, 1LL));
    }
    const std::size_t storage = security ? TINY_SECURED_STORAGE : TINY_TUPLE_STORAGE_SIZE;
    if (t.data.size() > 255 || TINY_SUBKEY_SIZE * key->len + t.data.size() > storage ||
        tiny_tuple_set_key_data(&write.request, &*key, t.data.data(),
                                static_cast<std::uint8_t>(t.data.size())) != 0) {
      ++counters.writesRefused;
      decide(Error(ErrorCode::TooLarge, "a tiny tuple holds at most " +
                                            std::to_string(storage - TINY_SUBKEY_SIZE * key->len) +
                                            " data bytes with this key" +
                                            (security ? " on a secured radio" : "") + "; " +
                                            std::to_string(t.data.size()) + " given"));
      return;
    }
    write.decide = decide;
    write.deadline = now + config.writeDeadline;
    pending.push_back(std::move(write));
    sendWrite(pending.back(), now);
  }

  void sendWrite(PendingWrite& write, Clock::time_point now) {
    std::uint8_t buf[TINY_FRAME_MAX];
    sendFrame(buf, tiny_encode_write_frame(buf, config.tinyId, frameSeq++, &write.request));
    write.lastSent = now;
    ++write.sends;
    ++counters.writesSent;
  }

  // --- tiny subscriptions to full PEIS tuples --------------------------------------
  void onTinySubscribe(const tiny_frame& f, Clock::time_point now) {
    // A subscription to a tiny node is that node's to answer.
    if (f.sub_owner != TINY_ANY_OWNER && (nodes.count(f.sub_owner) || f.sub_owner == config.tinyId))
      return;
    const ServedKey key{f.src, f.sub_owner, f.sub_flags, subKeys(f.sub_key)};
    auto it = served.find(key);
    if (f.type == TINY_FRAME_UNSUBSCRIBE) {
      if (it != served.end()) served.erase(it);
      return;
    }
    auto& node = nodes.at(f.src);
    if (it == served.end()) {
      const auto keyPattern =
          fullKeyPatternOf(registry, f.sub_key, (f.sub_flags & TINY_SUB_PREFIX) != 0);
      Served s;
      s.subscriber = f.src;
      try {
        s.pattern = f.sub_owner == TINY_ANY_OWNER ? Pattern(keyPattern)
                                                  : Pattern(keyPattern, PeisId{f.sub_owner});
        const auto subscriber = f.src;
        s.subscription = node.proxy->subscribe(s.pattern);
        s.callback = node.proxy->onChange(s.pattern, [this, subscriber, key](const Tuple& t) {
          post([this, subscriber, key, t] {
            if (served.count(key)) forward(subscriber, t);
          });
        });
      } catch (const std::exception& e) {
        log::warn(kernel.id(), "tinybridge: cannot serve tiny node " + std::to_string(f.src) +
                                   "'s subscription to " + keyPattern + ": " + e.what());
        return;
      }
      log::info(
          kernel.id(),
          "tinybridge: serving tiny node " + std::to_string(f.src) + "'s subscription to " +
              (f.sub_owner == TINY_ANY_OWNER ? std::string("*") : std::to_string(f.sub_owner)) +
              "." + keyPattern);
      ++counters.servedSubscriptions;
      it = served.emplace(key, std::move(s)).first;
    }
    it->second.lastRenew = now;
    // Answer every (re)subscription with the current values, as an owner
    // node does: a value lost on the radio comes again at the next renewal.
    for (const auto& t : node.proxy->find(it->second.pattern)) forward(f.src, t);
  }

  // A full PEIS's tuple to a tiny subscriber.
  void forward(std::uint16_t subscriber, const Tuple& t) {
    if (t.owner > 0xFFFE) {
      ++counters.forwardUnmappable;
      return;
    }
    if (nodes.count(static_cast<std::uint16_t>(t.owner))) return;  // a tiny node's: on the air
    std::string why;
    auto key = tinyKeyOf(registry, t.key, false, &why);
    tiny_tuple out{};
    const std::size_t storage = security ? TINY_SECURED_STORAGE : TINY_TUPLE_STORAGE_SIZE;
    if (!key || t.data.size() > 255 || TINY_SUBKEY_SIZE * key->len + t.data.size() > storage ||
        tiny_tuple_set_key_data(&out, &*key, t.data.data(),
                                static_cast<std::uint8_t>(t.data.size())) != 0) {
      ++counters.forwardUnmappable;
      log::debug(kernel.id(), "tinybridge: " + t.fullName() + " cannot go to tiny node " +
                                  std::to_string(subscriber) + ": " +
                                  (key ? std::string("too large") : why));
      return;
    }
    auto& seq = forwarded[TupleRef{t.owner, t.key}];
    if (seq.tinySeqno == 0 || seq.fullSeqno != t.seqno || seq.tsWrite != t.ts_write) {
      seq.fullSeqno = t.seqno;
      seq.tsWrite = t.ts_write;
      seq.tinySeqno = ++forwardCounter;
      if (seq.tinySeqno == 0) seq.tinySeqno = ++forwardCounter;
    }
    out.owner = static_cast<std::uint16_t>(t.owner);
    out.creator =
        t.creator >= 1 && t.creator <= 0xFFFE ? static_cast<std::uint16_t>(t.creator) : out.owner;
    out.seqno = seq.tinySeqno;
    out.ts_write = msOf(t.ts_write);
    out.ts_user = msOf(t.ts_user);
    if (t.ts_expire != kNoTime) {
      const auto left = tinyLifetime(t.ts_expire);
      if (left < 0) return;
      out.ts_expire = static_cast<std::uint32_t>(left);
    }
    std::uint8_t buf[TINY_FRAME_MAX];
    sendFrame(buf, tiny_encode_tuple_frame(buf, config.tinyId, subscriber, frameSeq++, &out));
    ++counters.tuplesForwarded;
  }

  // --- time --------------------------------------------------------------------------
  void tick(Clock::time_point now) {
    if (now - lastBeacon >= kBeaconEvery) sendBeacon(now);
    std::vector<std::uint16_t> silent;
    for (auto& [id, node] : nodes) {
      if (now - node.lastHeard > config.nodeTimeout) {
        silent.push_back(id);
      } else if (now - node.lastSubscribe >= kNodeSubscribeEvery) {
        subscribeToNode(node, now);
      }
    }
    for (auto id : silent)
      dropNode(id, "not heard for " + std::to_string(config.nodeTimeout.count()) + " ms");
    for (auto s = served.begin(); s != served.end();) {
      if (now - s->second.lastRenew > kServedTimeout) {
        log::info(kernel.id(), "tinybridge: tiny node " + std::to_string(s->second.subscriber) +
                                   " stopped renewing " + s->second.pattern.keyPattern());
        auto node = nodes.find(s->second.subscriber);
        if (node != nodes.end()) {
          node->second.proxy->removeCallback(s->second.callback);
          node->second.proxy->unsubscribe(s->second.subscription);
        }
        s = served.erase(s);
      } else {
        ++s;
      }
    }
    for (auto p = pending.begin(); p != pending.end();) {
      if (now >= p->deadline) {
        p->decide(Error(ErrorCode::Unreachable,
                        "tiny node " + std::to_string(p->node) + " did not confirm the write in " +
                            std::to_string(config.writeDeadline.count()) + " ms (" +
                            std::to_string(p->sends) + " sends)"));
        ++counters.writesFailed;
        p = pending.erase(p);
      } else {
        if (now - p->lastSent >= config.writeRetry) sendWrite(*p, now);
        ++p;
      }
    }
    publishStats();
  }

  std::string run() {
    auto nextTick = Clock::now();
    while (!stopping.load()) {
      if (kernel.quitRequested()) {
        publishStats();
        return "the bridge PEIS was told to quit";
      }
      const auto now = Clock::now();
      if (now >= nextTick) {
        tick(now);
        nextTick = now + kTick;
      }
      const int linkWait = link->service();
      const auto tickWait =
          std::chrono::duration_cast<milliseconds>(nextTick - Clock::now()).count();
      const int wait =
          static_cast<int>(std::max<long long>(0, std::min<long long>(linkWait, tickWait)));
      pollfd fds[2] = {{wake[0], POLLIN, 0}, {link->fd(), POLLIN, 0}};
      const int count = link->fd() >= 0 ? 2 : 1;
      (void)::poll(fds, count, wait);
      if (fds[0].revents & POLLIN) {
        char drain[64];
        while (::read(wake[0], drain, sizeof drain) > 0) {
        }
      }
      const auto at = Clock::now();
      for (const auto& frame : link->receive()) onFrame(frame, at);
      runInbox();
    }
    publishStats();
    return "stopped";
  }
};

TinyBridge::TinyBridge(BridgeConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}
TinyBridge::~TinyBridge() = default;
Kernel& TinyBridge::kernel() { return impl_->kernel; }
std::string TinyBridge::run() { return impl_->run(); }

void TinyBridge::stop() {
  impl_->stopping.store(true);
  const char byte = 0;
  (void)!::write(impl_->wake[1], &byte, 1);
}

BridgeStats TinyBridge::stats() const {
  std::lock_guard lock(impl_->statsMu);
  return impl_->statsSnapshot;
}

}  // namespace peis::bridge
