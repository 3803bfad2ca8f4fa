// The kernel and its network: starting and stopping the Network, applying
// what it reports (routed messages, PEIS up and down, topology, an id
// re-pick) to Replication under `mu`, sending remote writes, holding them
// at the write gate, and keeping the membership tuples (kernel.peers,
// kernel.links, kernel.subscribers) current. Kernel thread, except the
// checks at the start of remoteWrite.
#include <cstdlib>
#include <random>

#include "kernel_impl.h"
#include "log.h"
#include "membership.h"
#include "security/policy.h"

namespace peis {

namespace {
// Remote writes with at most this much data are sent again while unanswered.
constexpr std::size_t kRetriedWriteBytes = 64 * 1024;
}  // namespace
namespace asio = boost::asio;

namespace {

net::DiscoveryScope discoveryScope(const Options& options) {
  if (!options.discovery) return net::DiscoveryScope::Off;
  const char* env = std::getenv("PEIS_DISCOVERY_SCOPE");
  return env && *env ? net::parseDiscoveryScope(env) : net::DiscoveryScope::Lan;
}

}  // namespace

void Kernel::Impl::startNetwork() {  // kernel thread
  net::NetworkConfig config;
  config.ecology = options.ecology;
  config.name = name;
  config.port = options.port;
  config.connect = options.connect;
  config.discovery = discoveryScope(options);
  config.discoveryPort = options.discoveryPort;
  config.deadAfter = options.liveness;
  config.pingPeriod = std::max(options.liveness / 4, std::chrono::milliseconds(25));
  config.maxDataBytes = options.maxDataBytes;
  config.stalledAfter = options.liveness;
  config.tool = options.tool;
  config.handshakeTimeout = options.limits.handshake;
  config.maxConnections = options.limits.maxConnections;
  config.maxHandshakesPerHost = options.limits.maxHandshakesPerHost;
  config.maxRoutes = options.limits.maxRoutes;
  config.maxHeldBytes = options.limits.maxHeldBytes;
  config.idClaimWindow = options.limits.idClaimWindow;
  config.relayGrace = options.limits.relayGrace;
  config.credentials = credentials;
  net::Network::Events events;
  events.onMessages = [this](std::span<wire::RoutedMessage> m) { onMessages(m); };
  events.onPeerUp = [this](const net::PeerInfo& p) { onPeerUp(p); };
  events.onPeerDown = [this](PeisId p) { onPeerDown(p); };
  events.repickId = [this] { return repickId(); };
  events.onWritable = [this] { onWritable(); };
  events.onTopology = [this] { onTopology(); };
  if (credentials) {
    events.refuseIdentity = [this](const security::Identity& identity) {
      MutexLock lock(mu);
      return replication.guard().refusal(identity);
    };
  }
  network = std::make_unique<net::Network>(io, config, id, incarnation, events);
  network->start();
  MutexLock lock(mu);
  if (credentials) {
    // The guard asks on the kernel thread, which owns the network.
    replication.guard().secure(
        [this](PeisId peer) { return network ? network->identityOf(peer) : nullptr; },
        *initialPolicy);
  }
  space.setKernelTuple(special::kPort, std::to_string(network->port()));
  snapshotPeers();
  leaseLoop();
}

void Kernel::Impl::stopNetwork(std::function<void()> closed) {  // kernel thread
  leaseTimer.cancel();
  // What the outbox holds ready (a stream's updates waiting for the flush
  // timer, say) goes to the links before the Leave: a PEIS's last writes
  // reach their subscribers.
  if (network) flush();
  {
    MutexLock lock(mu);
    networkStopped = true;
    directLinks.clear();
    outboxDrained.notify_all();
  }
  retryTimer.cancel();
  flushTimer.cancel();
  quietTrim.stop();
  remoteWrites.failAll(Error(ErrorCode::Stopped, "the kernel is shutting down"));
  if (network) {
    network->stop(std::move(closed));
  } else if (closed) {
    closed();
  }
}

void Kernel::Impl::snapshotPeers() {
  peerSnapshot.clear();
  std::map<PeisId, PeisId> hops;
  for (const auto& peer : network->peers()) {
    peerSnapshot.push_back(PeerInfo{peer.id, peer.name, peer.hops, peer.incarnation, peer.tool});
    hops[peer.id] = peer.nextHop;
    // A route that goes another way may let a value pass that the old way
    // withheld (a PEIS on it with a smaller data limit).
    if (const auto before = nextHops.find(peer.id);
        before != nextHops.end() && before->second != peer.nextHop) {
      replication.onRouteChanged(peer.id);
    }
  }
  nextHops = std::move(hops);
}

void Kernel::Impl::refreshMembershipTuples() {
  space.refreshIndirects();  // names in meta tuples may resolve now
  auto text = membershipText(peerSnapshot);
  if (auto t = space.get(id, special::kPeers); !t || t->data != text.peers) {
    space.setKernelTuple(special::kPeers, std::move(text.peers));
  }
  if (auto t = space.get(id, special::kLinks); !t || t->data != text.links) {
    space.setKernelTuple(special::kLinks, std::move(text.links));
  }
}

void Kernel::Impl::refreshSubscribersTuple() {
  auto text = joinIds(replication.subscribers());
  if (text == publishedSubscribers) return;
  publishedSubscribers = text;
  space.setKernelTuple(special::kSubscribers, std::move(text));
}

void Kernel::Impl::onTopology() {
  quietTrim.noteChange();
  MutexLock lock(mu);
  forgetDirectLinks();
  snapshotPeers();
  refreshMembershipTuples();
  afterMutation();
}

void Kernel::Impl::onPeerUp(const net::PeerInfo& peer) {
  MutexLock lock(mu);
  log::debug(id, "PEIS " + std::to_string(peer.id) + " '" + peer.name + "' reachable in " +
                     std::to_string(peer.hops) + " hop(s)");
  replication.onPeerUp(peer.id, peer.incarnation);
  afterMutation();  // the membership tuples follow with onTopology, once per change
}

void Kernel::Impl::onPeerDown(PeisId peer) {
  {
    MutexLock lock(mu);
    log::debug(id, "PEIS " + std::to_string(peer) + " is gone");
    replication.onPeerDown(peer);
    replication.outbox().drop(peer);  // nothing waits for a PEIS that is gone
    noteOutboxDrained();
    refreshSubscribersTuple();  // the membership tuples follow with onTopology
    afterMutation();
  }
  remoteWrites.failOwner(
      peer, Error(ErrorCode::Unreachable, "PEIS " + std::to_string(peer) + " went away"));
}

void Kernel::Impl::applyWrite(PeisId source, const wire::Write& write) {
  replication.onWrite(source, write);
  if (write.tuple.owner != id) return;
  if (auto t = space.get(id, write.tuple.key); t && t->ts_expire != kNoTime) noteExpiry(*t);
}

// Asks the write gate about a remote set of an own tuple (outside the
// lock); applies or refuses it now or when the gate decides.
void Kernel::Impl::holdWrite(const WriteGate& gate, PeisId source, wire::Write&& write) {
  auto held = std::make_shared<wire::Write>(std::move(write));
  auto decided = std::make_shared<std::atomic<bool>>(false);
  auto gateTimer = std::make_shared<asio::steady_timer>(io);  // the writer's deadline
  WriteDecision decide = [this, source, held, decided,
                          gateTimer](const std::optional<Error>& refusal) {
    if (decided->exchange(true)) return;
    // A deep copy: a copied std::runtime_error shares its message with the
    // gate's (a reference count ThreadSanitizer cannot see), which the
    // gate's thread may destroy while the kernel thread reads it.
    std::optional<Error> own;
    if (refusal) own.emplace(refusal->code(), std::string(refusal->what()));
    asio::post(io, [this, source, held, refusal = std::move(own), gateTimer] {
      gateTimer->cancel();
      MutexLock lock(mu);
      if (refusal) {
        replication.refuseWrite(source, *held, *refusal);
      } else {
        applyWrite(source, *held);
      }
      afterMutation();
    });
  };
  bool holding = false;
  try {
    holding = gate && gate(held->tuple, source, decide);
  } catch (const std::exception& e) {
    decide(Error(ErrorCode::Refused, std::string("write gate failed: ") + e.what()));
    return;
  }
  if (!holding) return decide(std::nullopt);
  if (held->waitMs == 0) return;
  // Answer while the writer still waits, with the reason, rather than let
  // its deadline pass (docs/protocol.md §12).
  const auto hold = std::chrono::milliseconds(held->waitMs) * 3 / 4;
  gateTimer->expires_after(hold);
  gateTimer->async_wait([decide, hold, waitMs = held->waitMs](const boost::system::error_code& ec) {
    if (ec) return;
    decide(Error(ErrorCode::Timeout, "its write gate held the write for " +
                                         std::to_string(hold.count()) +
                                         " ms without a decision (the writer waits " +
                                         std::to_string(waitMs) + " ms)"));
  });
}

// Messages that arrived together (one socket read) are applied under one
// lock; write results complete outside it.
void Kernel::Impl::onMessages(std::span<wire::RoutedMessage> messages) {
  std::vector<std::pair<PeisId, wire::WriteResult>> results;
  std::vector<std::pair<PeisId, wire::Write>> gated;
  WriteGate gate;
  drainInline = true;  // the deliveries run below, without a post
  // Should a message throw below, what the handler deferred is not left
  // waiting for the next message: posted instead, and waiters woken.
  struct DeferredOnThrow {
    Impl& k;
    ~DeferredOnThrow() {
      if (!k.drainInline) return;  // the normal way out, below
      k.drainInline = false;
      for (const auto& waiter : k.wakeAfterUnlock) waiter->wake();
      k.wakeAfterUnlock.clear();
      if (std::exchange(k.flushDeferred, false)) asio::post(k.io, [&k = k] { k.flush(); });
      if (std::exchange(k.drainDeferred, false)) asio::post(k.io, [&k = k] { k.drain(); });
    }
  } deferredOnThrow{*this};
  {
    MutexLock lock(mu);
    receivedSinceDirect = true;  // an answer may follow: send it at once
    for (auto& message : messages) {
      const auto source = message.envelope.source;
      std::visit(
          [&](auto&& body) {
            mu.assertHeld();
            using T = std::decay_t<decltype(body)>;
            if constexpr (std::is_same_v<T, wire::WriteResult>) {
              results.emplace_back(source, std::move(body));
            } else if constexpr (std::is_same_v<T, wire::Subscribe>) {
              replication.onSubscribe(source, body, std::chrono::steady_clock::now());
              refreshSubscribersTuple();
            } else if constexpr (std::is_same_v<T, wire::Unsubscribe>) {
              replication.onUnsubscribe(source, body.subscription);
              refreshSubscribersTuple();
            } else if constexpr (std::is_same_v<T, wire::TupleUpdate>) {
              const auto expiry = body.tuple.ts_expire;
              if (replication.onUpdate(source, std::move(body)) && expiry != kNoTime) {
                asio::post(io, [this, expiry] { scheduleExpiry(expiry); });
              }
            } else if constexpr (std::is_same_v<T, wire::TupleDeleted>) {
              replication.onDeleted(source, body);
            } else if constexpr (std::is_same_v<T, wire::TupleWithheld>) {
              replication.onWithheld(std::move(body));
            } else if constexpr (std::is_same_v<T, wire::KeyManifest>) {
              if (const auto dropped = replication.onKeyManifest(source, body)) {
                log::debug(id, "dropped " + std::to_string(dropped) + " tuple(s) of PEIS " +
                                   std::to_string(source) + " it deleted unheard");
              }
            } else if constexpr (std::is_same_v<T, wire::Write>) {
              if (!replication.firstTimeWrite(source, body.request)) {
                // Sent again by a writer that missed the answer: answered
                // once more if decided, else its first copy is being decided.
              } else if (writeGate && body.op == wire::WriteOp::Set && body.tuple.owner == id) {
                // Refused before the gate sees it: a gate may act on it (a
                // tiny node's proxy sends it to the node).
                if (auto refusal = replication.admit(source, body)) {
                  replication.refuseWrite(source, body, *refusal);
                } else {
                  gated.emplace_back(source, std::move(body));
                }
              } else {
                applyWrite(source, body);
              }
            }
          },
          std::move(message.body));
    }
    if (auto denied = replication.guard().takeDeniedText()) {
      space.setKernelTuple(special::kDenied, std::move(*denied));
    }
    afterMutation();
    if (!gated.empty()) gate = writeGate;
  }
  drainInline = false;
  // Threads waiting for what arrived (waitForNext) are woken once the lock
  // is free, before the callbacks run: they need not wait for those.
  for (const auto& waiter : wakeAfterUnlock) waiter->wake();
  wakeAfterUnlock.clear();
  for (auto& [source, write] : gated) holdWrite(gate, source, std::move(write));
  for (auto& [source, result] : results) remoteWrites.onResult(source, result);
  // What it queued goes out, and the callbacks of what arrived run, now, on
  // this turn of the loop (as a listener on a receive thread does), not
  // after a post.
  if (std::exchange(flushDeferred, false)) flush();
  if (std::exchange(drainDeferred, false)) drain();
}

PeisId Kernel::Impl::repickId() {
  MutexLock lock(mu);
  std::random_device device;
  std::uniform_int_distribution<PeisId> pick(1000, kMaxPeisId);
  const PeisId old = id;
  id = pick(device);
  space.changeSelf(id);
  replication.onSelfChanged();
  space.setKernelTuple(special::kId, std::to_string(id.load()));
  log::warn(id, "re-picked id " + std::to_string(id.load()) + " (" + std::to_string(old) +
                    " belongs to a PEIS that joined earlier)");
  afterMutation();
  return id;
}

void Kernel::Impl::remoteWrite(wire::WriteOp op, PeisId owner, std::string_view key,
                               std::string data, std::optional<std::uint64_t> ifSeqno,
                               const WriteOptions& writeOptions, WriteDone done) {
  validateKey(key);
  if (!isValidPeisId(owner)) {
    throw Error(ErrorCode::InvalidArgument, "invalid owner id " + std::to_string(owner));
  }
  if (data.size() > options.maxDataBytes) {
    throw Error(ErrorCode::TooLarge, "data is " + std::to_string(data.size()) +
                                         " bytes; this PEIS sends at most " +
                                         std::to_string(options.maxDataBytes));
  }
  wire::Write write;
  write.op = op;
  write.ifSeqno = ifSeqno;
  write.ttlMicros = std::max<std::int64_t>(writeOptions.ttl.count(), 0);    // <= 0: never expires
  write.waitMs = static_cast<std::uint32_t>(options.writeTimeout.count());  // validated to fit
  write.tuple.owner = owner;
  write.tuple.creator = id;
  write.tuple.key = std::string(key);
  write.tuple.data = std::move(data);
  write.tuple.mimetype = writeOptions.mimetype;
  write.tuple.encoding = writeOptions.encoding;
  write.tuple.ts_user = writeOptions.ts_user;
  write.tuple.ts_expire = writeOptions.ts_expire;
  asio::post(io, [this, write = std::move(write), done = std::move(done)]() mutable {
    const auto owner = write.tuple.owner;
    if (!network || !network->reachable(owner)) {
      if (done) {
        done(Error(ErrorCode::Unreachable, "PEIS " + std::to_string(owner) +
                                               " is not reachable from PEIS " +
                                               std::to_string(id.load())),
             0);
      }
      return;
    }
    // A write up to kRetriedWriteBytes is sent again while not answered (the
    // owner answers a repeated request id once); a bigger one relies on its
    // link alone rather than repeat megabytes on a slow one.
    std::function<void(std::uint64_t)> resend;
    if (write.tuple.data.size() <= kRetriedWriteBytes) {
      resend = [this, copy = std::make_shared<const wire::Write>(write)](std::uint64_t request) {
        auto again = *copy;
        again.request = request;
        if (network)
          network->send(wire::RoutedMessage{wire::Envelope{0, again.tuple.owner, wire::kDefaultTtl},
                                            std::move(again)});
      };
    }
    write.request = remoteWrites.add(owner, std::move(done), options.writeTimeout, resend);
    const auto request = write.request;
    if (!network->send(wire::RoutedMessage{wire::Envelope{0, owner, wire::kDefaultTtl}, write})) {
      remoteWrites.complete(
          request, Error(ErrorCode::Unreachable, "no route to PEIS " + std::to_string(owner)), 0);
    }
  });
}

}  // namespace peis
