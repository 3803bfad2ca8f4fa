// Kernel: glues the TupleSpace to one kernel thread (Boost.Asio io_context).
// Public calls lock the space, mutate it and queue deliveries; the kernel
// thread runs the deliveries with no lock held, so callbacks may call the API.
#include "peis/kernel.h"

#include <pthread.h>
#include <pwd.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <future>
#include <iostream>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include "adaptive_mutex.h"
#include "log.h"
#include "net/network.h"
#include "peis/error.h"
#include "replication.h"
#include "saturating_time.h"
#include "tuple_space.h"

namespace peis {
namespace asio = boost::asio;

namespace {

constexpr std::size_t kDeliveriesPerTurn = 256;  // then let timers and posts run
constexpr std::size_t kMessagesPerTurn = 1024;   // network sends per turn, likewise
constexpr std::size_t kBytesPerTurn = 1u << 20;  // of tuple updates per turn, likewise
// A flush that carried this many messages is part of a stream: the next one
// waits kStreamFlushDelay to collect more (docs/architecture.md, "Flush").
constexpr std::size_t kStreamMessages = 16;
constexpr std::chrono::microseconds kStreamFlushDelay{50};

PeisId pickId(const Options& options) {
  if (options.id) return *options.id;
  std::random_device device;
  std::uniform_int_distribution<PeisId> pick(1000, kMaxPeisId);
  return pick(device);
}

std::string pickName(const Options& options, PeisId id) {
  if (!options.name.empty()) return options.name;
  std::string name;
  for (char c : options.programName) {
    name += (static_cast<unsigned char>(c) > 0x20 && static_cast<unsigned char>(c) < 0x7f &&
             c != '.' && c != '*' && c != '=')
                ? c
                : '-';
  }
  if (name.size() > kMaxNameBytes) name.resize(kMaxNameBytes);
  if (nameProblem(name)) name = "peis-" + std::to_string(id);
  return name;
}

std::string hostName() {
  char buffer[256] = {};
  if (gethostname(buffer, sizeof buffer - 1) != 0) return "unknown";
  return buffer;
}

net::DiscoveryScope discoveryScope(const Options& options) {
  if (!options.discovery) return net::DiscoveryScope::Off;
  const char* env = std::getenv("PEIS_DISCOVERY_SCOPE");
  return env && *env ? net::parseDiscoveryScope(env) : net::DiscoveryScope::Lan;
}

std::string joinIds(const std::vector<PeisId>& ids) {
  std::string text;
  for (auto id : ids) text += (text.empty() ? "" : " ") + std::to_string(id);
  return text;
}

std::string userName() {
  if (const char* user = std::getenv("USER"); user && *user) return user;
  if (const passwd* entry = getpwuid(getuid())) return entry->pw_name;
  return "unknown";
}

}  // namespace

const char* versionString() { return "0.1.0"; }

struct Kernel::Impl {
  Options options;
  std::atomic<PeisId> id;
  std::string name;
  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> work{io.get_executor()};
  std::thread thread;
  std::thread::id threadId;

  std::uint64_t incarnation = static_cast<std::uint64_t>(systemNow().time_since_epoch().count());

  mutable AdaptiveMutex mu;  // guards everything below down to `peerSnapshot`
  mutable std::condition_variable_any changed;
  TupleSpace space;
  Replication replication;
  bool drainScheduled = false;
  bool flushScheduled = false;
  mutable int waiters = 0;
  std::vector<PeerInfo> peerSnapshot;
  std::string publishedSubscribers;

  // Kernel thread only.
  std::unique_ptr<net::Network> network;
  struct PendingWrite {
    WriteDone done;
    std::shared_ptr<asio::steady_timer> timer;
    PeisId owner = 0;
  };
  std::map<std::uint64_t, PendingWrite> pendingWrites;
  std::uint64_t nextRequest = 1;
  WriteGate writeGate;  // guarded by mu
  asio::steady_timer leaseTimer{io};
  asio::steady_timer retryTimer{io};  // Replication::retryUnanswered
  bool retryArmed = false;            // guarded by mu
  bool networkStopped = false;        // guarded by mu

  std::mutex timersMu;
  struct Timer {
    std::shared_ptr<asio::steady_timer> timer;
    std::function<void()> fn;
    std::chrono::milliseconds period{0};
    std::atomic<bool> active{true};
    TimerHandle handle = 0;
  };
  std::map<TimerHandle, std::shared_ptr<Timer>> timers;
  TimerHandle nextTimer = 1;

  asio::steady_timer expiryTimer{io};
  Timestamp scheduledExpiry = kNoTime;  // kernel thread only

  mutable std::mutex quitMu;
  std::condition_variable quitCv;
  bool quitting = false;
  std::string quitReason;
  std::atomic<std::uint64_t> callbackErrors{0};

  Impl(Options opts, PeisId pickedId)
      : options(std::move(opts)),
        id(pickedId),
        name(pickName(options, id)),
        space(id, systemNow, SpaceLimits{options.maxDataBytes}),
        replication(space, incarnation, options.subscriptionLease) {
    space.setObserver(
        [this](EventKind kind, const TuplePtr& t) { replication.onLocalEvent(kind, t); });
    space.setNameSource([this](std::string_view wanted) {  // mu held
      std::vector<PeisId> ids;
      for (const auto& peer : peerSnapshot) {
        if (peer.name == wanted) ids.push_back(peer.id);
      }
      return ids;
    });
    space.setRetargetObserver(
        [this](CallbackId id, const std::optional<TupleRef>&, const std::optional<TupleRef>& to) {
          replication.onRetarget(id, to);
        });
  }

  // Runs `fn` on the space under the lock, then wakes the kernel thread and
  // blocked readers as needed.
  template <typename F>
  auto mutate(F&& fn) {
    std::unique_lock lock(mu);
    auto result = fn(space);
    afterMutation();
    return result;
  }

  void afterMutation() {  // mu held
    if (!flushScheduled && replication.hasOutgoing()) {
      flushScheduled = true;
      asio::post(io, [this] { flush(); });
    }
    if (!drainScheduled && (space.hasPendingDeliveries() || space.allKeysDirty())) {
      drainScheduled = true;
      asio::post(io, [this] { drain(); });
    }
    if (waiters > 0) changed.notify_all();
    if (!retryArmed && replication.hasUnanswered()) {
      retryArmed = true;
      asio::post(io, [this] { armRetry(); });
    }
  }

  void armRetry() {  // kernel thread
    std::optional<std::chrono::steady_clock::time_point> at;
    {
      std::lock_guard lock(mu);
      at = replication.nextRetry();
      if (!at || networkStopped) {
        retryArmed = false;
        return;
      }
    }
    retryTimer.expires_at(*at);
    retryTimer.async_wait([this](const boost::system::error_code& ec) {
      std::lock_guard lock(mu);
      retryArmed = false;
      if (ec) return;
      replication.retryUnanswered(std::chrono::steady_clock::now());
      afterMutation();  // sends them, and arms the timer again if more are due
    });
  }

  // Kernel thread: deliveries taken from the space, run in turns.
  std::deque<TupleSpace::Delivery> batch;

  void drain() {
    for (std::size_t ran = 0;; ++ran) {
      if (batch.empty()) {
        std::lock_guard lock(mu);
        space.takeAllDeliveries(batch);  // a swap: one lock for all queued
        if (batch.empty()) {
          if (space.allKeysDirty()) {
            space.flushAllKeys();  // may queue deliveries of its own
            if (waiters > 0) changed.notify_all();
            continue;
          }
          drainScheduled = false;
          return;
        }
      }
      if (ran == kDeliveriesPerTurn) {
        asio::post(io, [this] { drain(); });  // more: yield to timers and sockets first
        return;
      }
      const auto& delivery = batch.front();
      // Each throwing callback is counted; the others for the event still run.
      delivery.run([&](std::exception_ptr error) {
        ++callbackErrors;
        const auto what = delivery.tuple() ? delivery.tuple()->fullName() : std::string("?");
        try {
          std::rethrow_exception(error);
        } catch (const std::exception& e) {
          log::error(id, "a callback for " + what + " threw: " + e.what());
        } catch (...) {
          log::error(id, "a callback for " + what + " threw");
        }
      });
      batch.pop_front();
    }
  }

  void noteExpiry(const Tuple& tuple) {
    if (tuple.ts_expire == kNoTime) return;
    asio::post(io, [this, at = tuple.ts_expire] { scheduleExpiry(at); });
  }

  void scheduleExpiry(Timestamp at) {  // kernel thread
    if (scheduledExpiry != kNoTime && scheduledExpiry <= at) return;
    scheduledExpiry = at;
    expiryTimer.expires_after(timerWait(at, systemNow()));  // far-off: fires early, re-armed
    expiryTimer.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;  // re-scheduled earlier or shutting down
      scheduledExpiry = kNoTime;
      const auto next = mutate([](TupleSpace& s) {
        s.expire();
        return s.nextExpiry();
      });
      if (next != kNoTime) scheduleExpiry(next);
    });
  }

  void requestQuit(std::string reason) {
    {
      std::lock_guard lock(quitMu);
      if (quitting) return;
      quitting = true;
      quitReason = std::move(reason);
    }
    log::info(id, "quitting: " + quitReason);
    quitCv.notify_all();
  }

  void startTimer(const std::shared_ptr<Timer>& timer, std::chrono::milliseconds delay) {
    timer->timer->expires_after(saturatingCast<std::chrono::steady_clock::duration>(delay));
    timer->timer->async_wait([this, timer](const boost::system::error_code& ec) {
      if (ec || !timer->active) return;
      if (timer->period.count() == 0) {
        // A one-shot timer leaves the table as it fires (it would stay there
        // forever otherwise); if cancelTimer() took it first, it does not run.
        std::lock_guard lock(timersMu);
        if (timers.erase(timer->handle) == 0) return;
      }
      try {
        timer->fn();
      } catch (const std::exception& e) {
        ++callbackErrors;
        log::error(id, std::string("a timer callback threw: ") + e.what());
      } catch (...) {  // anything else would end the kernel thread (std::terminate)
        ++callbackErrors;
        log::error(id, "a timer callback threw");
      }
      if (timer->period.count() > 0 && timer->active) startTimer(timer, timer->period);
    });
  }

  TimerHandle addTimer(std::chrono::milliseconds delay, std::chrono::milliseconds period,
                       std::function<void()> fn) {
    auto timer = std::make_shared<Timer>();
    timer->timer = std::make_shared<asio::steady_timer>(io);
    timer->fn = std::move(fn);
    timer->period = period;
    TimerHandle handle;
    {
      std::lock_guard lock(timersMu);
      handle = nextTimer++;
      timer->handle = handle;
      timers.emplace(handle, timer);
    }
    asio::post(io, [this, timer, delay] { startTimer(timer, delay); });
    return handle;
  }

  // --- network glue (kernel thread) -------------------------------------------
  std::vector<Replication::Outgoing> outgoing;  // kernel thread: flush's, reused
  asio::steady_timer flushTimer{io};
  std::vector<std::string> sentFrames;  // kernel thread: frames handed to links

  void flush() {
    if (network && network->congested()) return;  // onWritable posts flush again
    outgoing.clear();
    {
      std::lock_guard lock(mu);
      for (auto& frames : sentFrames) replication.recycleFrames(std::move(frames));
      sentFrames.clear();
      replication.takeOutbox(outgoing, kMessagesPerTurn, kBytesPerTurn);
      std::size_t messages = 0;
      for (const auto& out : outgoing) messages += out.frameCount > 0 ? out.frameCount : 1;
      if (replication.hasOutgoing()) {
        asio::post(io, [this] { flush(); });  // more: let the sockets drain first
      } else if (messages >= kStreamMessages) {
        // A writer is streaming: collect its next updates for a moment
        // rather than have every few of them wake this thread (which costs
        // the writer a system call each time). flushScheduled stays set.
        flushTimer.expires_after(kStreamFlushDelay);
        flushTimer.async_wait([this](const boost::system::error_code& ec) {
          if (!ec) flush();
        });
      } else {
        flushScheduled = false;
      }
    }
    for (auto& out : outgoing) {
      if (!network) break;
      if (out.frameCount > 0) {
        network->sendFrames(out.destination, out.frames, out.frameCount);
        sentFrames.push_back(std::move(out.frames));  // its memory goes back at the next flush
      } else if (out.update) {
        network->sendUpdate(out.destination, incarnation, out.update);
      } else {
        network->send(wire::RoutedMessage{wire::Envelope{0, out.destination, wire::kDefaultTtl},
                                          std::move(*out.body)});
      }
    }
    outgoing.clear();  // drop the references to sent tuples now
  }

  void refreshMembershipTuples() {  // mu held
    space.refreshIndirects();       // names in meta tuples may resolve now
    std::vector<PeisId> ids, linked;
    for (const auto& peer : peerSnapshot) {
      if (peer.hops > 0) ids.push_back(peer.id);
      if (peer.hops == 1) linked.push_back(peer.id);
    }
    auto peersText = joinIds(ids), linksText = joinIds(linked);
    if (auto t = space.get(id, special::kPeers); !t || t->data != peersText) {
      space.setKernelTuple(special::kPeers, std::move(peersText));
    }
    if (auto t = space.get(id, special::kLinks); !t || t->data != linksText) {
      space.setKernelTuple(special::kLinks, std::move(linksText));
    }
  }

  void refreshSubscribersTuple() {  // mu held
    auto text = joinIds(replication.subscribers());
    if (text == publishedSubscribers) return;
    publishedSubscribers = text;
    space.setKernelTuple(special::kSubscribers, std::move(text));
  }

  void snapshotPeers() {  // mu held, kernel thread
    peerSnapshot.clear();
    for (const auto& peer : network->peers()) {
      peerSnapshot.push_back(PeerInfo{peer.id, peer.name, peer.hops, peer.incarnation});
    }
  }

  void onPeerUp(const net::PeerInfo& peer) {
    std::lock_guard lock(mu);
    log::debug(id, "PEIS " + std::to_string(peer.id) + " '" + peer.name + "' reachable in " +
                       std::to_string(peer.hops) + " hop(s)");
    replication.onPeerUp(peer.id, peer.incarnation);
    afterMutation();  // the membership tuples follow with onTopology, once per change
  }

  // Asks the write gate about a remote set of an own tuple (outside the
  // lock); applies or refuses it now or when the gate decides.
  void holdWrite(const WriteGate& gate, PeisId source, wire::Write&& write) {
    auto held = std::make_shared<wire::Write>(std::move(write));
    auto decided = std::make_shared<std::atomic<bool>>(false);
    auto gateTimer = std::make_shared<asio::steady_timer>(io);  // the writer's deadline
    WriteDecision decide = [this, source, held, decided,
                            gateTimer](const std::optional<Error>& refusal) {
      if (decided->exchange(true)) return;
      asio::post(io, [this, source, held, refusal, gateTimer] {
        gateTimer->cancel();
        std::lock_guard lock(mu);
        if (refusal) {
          replication.refuseWrite(source, *held, *refusal);
        } else {
          replication.onWrite(source, *held);
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
    gateTimer->async_wait(
        [decide, hold, waitMs = held->waitMs](const boost::system::error_code& ec) {
          if (ec) return;
          decide(Error(ErrorCode::Timeout, "its write gate held the write for " +
                                               std::to_string(hold.count()) +
                                               " ms without a decision (the writer waits " +
                                               std::to_string(waitMs) + " ms)"));
        });
  }

  void onPeerDown(PeisId peer) {
    {
      std::lock_guard lock(mu);
      log::debug(id, "PEIS " + std::to_string(peer) + " is gone");
      replication.onPeerDown(peer);
      refreshSubscribersTuple();  // the membership tuples follow with onTopology
      afterMutation();
    }
    std::vector<std::uint64_t> failed;
    for (const auto& [request, pending] : pendingWrites) {
      if (pending.owner == peer) failed.push_back(request);
    }
    for (auto request : failed) {
      completeWrite(
          request, Error(ErrorCode::Unreachable, "PEIS " + std::to_string(peer) + " went away"), 0);
    }
  }

  // Messages that arrived together (one socket read) are applied under one
  // lock; write results complete outside it.
  void onMessages(std::vector<wire::RoutedMessage>&& messages) {
    std::vector<std::pair<PeisId, wire::WriteResult>> results;
    std::vector<std::pair<PeisId, wire::Write>> gated;
    {
      std::lock_guard lock(mu);
      for (auto& message : messages) {
        const auto source = message.envelope.source;
        std::visit(
            [&](auto&& body) {
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
              } else if constexpr (std::is_same_v<T, wire::Write>) {
                if (writeGate && body.op == wire::WriteOp::Set && body.tuple.owner == id) {
                  gated.emplace_back(source, std::move(body));
                } else {
                  replication.onWrite(source, body);
                }
              }
            },
            std::move(message.body));
      }
      afterMutation();
    }
    if (!gated.empty()) {
      WriteGate gate;
      {
        std::lock_guard lock(mu);
        gate = writeGate;
      }
      for (auto& [source, write] : gated) holdWrite(gate, source, std::move(write));
    }
    for (auto& [source, result] : results) {
      auto pending = pendingWrites.find(result.request);
      // A PEIS on the route may refuse the write for the owner (a frame over
      // its data limit); only the owner can accept it.
      if (pending == pendingWrites.end() || (pending->second.owner != source && result.status == 0))
        continue;
      if (result.status == 0) {
        completeWrite(result.request, std::nullopt, result.seqno);
      } else {
        const auto code = static_cast<ErrorCode>(
            std::min<int>(result.status - 1, static_cast<int>(ErrorCode::Stopped)));
        completeWrite(result.request,
                      Error(code, "PEIS " + std::to_string(source) + ": " + result.message), 0);
      }
    }
  }

  PeisId repickId() {
    std::lock_guard lock(mu);
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

  void remoteWrite(wire::WriteOp op, PeisId owner, std::string_view key, std::string data,
                   std::optional<std::uint64_t> ifSeqno, const WriteOptions& writeOptions,
                   WriteDone done) {
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
      write.request = nextRequest++;
      const auto request = write.request;
      auto timer = std::make_shared<asio::steady_timer>(io, options.writeTimeout);
      pendingWrites[request] = PendingWrite{std::move(done), timer, owner};
      timer->async_wait([this, request, owner](const boost::system::error_code& ec) {
        if (ec) return;
        completeWrite(
            request,
            Error(ErrorCode::Timeout, "PEIS " + std::to_string(owner) + " did not answer within " +
                                          std::to_string(options.writeTimeout.count()) + " ms"),
            0);
      });
      if (!network->send(wire::RoutedMessage{wire::Envelope{0, owner, wire::kDefaultTtl}, write})) {
        completeWrite(
            request, Error(ErrorCode::Unreachable, "no route to PEIS " + std::to_string(owner)), 0);
      }
    });
  }

  void completeWrite(std::uint64_t request, const std::optional<Error>& error,
                     std::uint64_t seqno) {
    auto it = pendingWrites.find(request);
    if (it == pendingWrites.end()) return;  // already timed out
    auto pending = std::move(it->second);
    pendingWrites.erase(it);
    pending.timer->cancel();
    if (!pending.done) return;
    try {
      pending.done(error, seqno);
    } catch (const std::exception& e) {
      ++callbackErrors;
      log::error(id, std::string("a write completion threw: ") + e.what());
    }
  }

  void leaseLoop() {
    leaseTimer.expires_after(options.subscriptionLease / 3);
    leaseTimer.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      {
        std::lock_guard lock(mu);
        replication.renew();
        if (replication.expireLeases(std::chrono::steady_clock::now())) refreshSubscribersTuple();
        afterMutation();
      }
      leaseLoop();
    });
  }

  void startNetwork() {  // kernel thread
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
    net::Network::Events events;
    events.onMessages = [this](std::vector<wire::RoutedMessage>&& m) { onMessages(std::move(m)); };
    events.onPeerUp = [this](const net::PeerInfo& p) { onPeerUp(p); };
    events.onPeerDown = [this](PeisId p) { onPeerDown(p); };
    events.repickId = [this] { return repickId(); };
    events.onWritable = [this] { flush(); };
    events.onTopology = [this] {
      std::lock_guard lock(mu);
      snapshotPeers();
      refreshMembershipTuples();
      afterMutation();
    };
    network = std::make_unique<net::Network>(io, config, id, incarnation, events);
    network->start();
    std::lock_guard lock(mu);
    space.setKernelTuple(special::kPort, std::to_string(network->port()));
    snapshotPeers();
    leaseLoop();
  }

  void stopNetwork() {  // kernel thread
    leaseTimer.cancel();
    {
      std::lock_guard lock(mu);
      networkStopped = true;
    }
    retryTimer.cancel();
    flushTimer.cancel();
    auto requests = pendingWrites;
    for (const auto& [request, pending] : requests) {
      completeWrite(request, Error(ErrorCode::Stopped, "the kernel is shutting down"), 0);
    }
    if (network) network->stop();
  }

  // Runs `fn` on the kernel thread and waits for it (not from the kernel thread).
  template <typename F>
  void onKernelThreadAndWait(F&& fn) {
    std::promise<void> done;
    asio::post(io, [&] {
      try {
        fn();
        done.set_value();
      } catch (...) {
        done.set_exception(std::current_exception());
      }
    });
    done.get_future().get();
  }

  void publishSpecialTuples() {
    mutate([&](TupleSpace& s) {
      s.setKernelTuple(special::kName, name);
      s.setKernelTuple(special::kId, std::to_string(id));
      s.setKernelTuple(special::kHostname, hostName());
      s.setKernelTuple(special::kUser, userName());
      s.setKernelTuple(special::kVersion, versionString());
      s.setKernelTuple(special::kSubscribers, "");
      s.setKernelTuple(special::kLinks, "");
      s.setKernelTuple(special::kDoQuit, "no");
      s.setKernelTuple(special::kPeers, "");
      s.setKernelTuple(special::kPort, "0");
      s.setKernelTuple(special::kStarted, std::to_string(incarnation));
      s.addCallback(
          Pattern::exact(id, special::kDoQuit), kOnChange, [this](EventKind, const Tuple& t) {
            if (t.data == "yes") {
              requestQuit("kernel.do-quit set to yes by PEIS " + std::to_string(t.creator));
            }
          });
      for (const auto& [key, value] : options.setTuples) s.set(key, value);
      s.flushAllKeys();
      return 0;
    });
  }
};

Kernel::Kernel(Options options) {
  options.validate();
  const auto id = pickId(options);
  impl_ = std::make_unique<Impl>(std::move(options), id);
  impl_->thread = std::thread([impl = impl_.get()] {
    pthread_setname_np(pthread_self(), "peis-kernel");  // for top -H, perf
    impl->io.run();
  });
  impl_->threadId = impl_->thread.get_id();
  try {
    impl_->publishSpecialTuples();
    if (impl_->options.network)
      impl_->onKernelThreadAndWait([impl = impl_.get()] { impl->startNetwork(); });
  } catch (...) {
    impl_->work.reset();
    impl_->io.stop();
    impl_->thread.join();
    throw;
  }
  log::info(id, "started as '" + impl_->name + "' (ecology " + impl_->options.ecology + ")");
}

namespace {
Options parseOrExit(int& argc, char** argv) {
  try {
    auto options = Options::fromArgs(argc, argv);
    if (options.help) {
      std::cout << "Usage: " << (options.programName.empty() ? "program" : options.programName)
                << " [options]\n\n"
                << Options::helpText();
      std::exit(0);
    }
    return options;
  } catch (const Error& e) {
    std::cerr << (argc > 0 && argv[0] ? argv[0] : "peis") << ": " << e.what() << "\n";
    std::exit(2);
  }
}
}  // namespace

Kernel::Kernel(int& argc, char** argv) : Kernel(parseOrExit(argc, argv)) {}

Kernel::~Kernel() {
  impl_->onKernelThreadAndWait([impl = impl_.get()] { impl->stopNetwork(); });
  {
    std::lock_guard lock(impl_->timersMu);
    for (auto& [handle, timer] : impl_->timers) timer->active = false;
  }
  impl_->work.reset();
  impl_->io.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

PeisId Kernel::id() const { return impl_->id; }
std::string Kernel::name() const { return impl_->name; }
const Options& Kernel::options() const { return impl_->options; }

Tuple Kernel::set(std::string_view key, std::string data, const WriteOptions& options) {
  bool backedUp = false;
  auto tuple = impl_->mutate([&](TupleSpace& s) {
    auto stored = s.set(key, std::move(data), options);
    backedUp = impl_->replication.outboxBytes() >= Replication::kTrackOutboxAbove;
    return stored;
  });
  impl_->noteExpiry(*tuple);
  // A writer that outruns the network (its updates have started to wait in
  // the outbox, to be coalesced) gives up the rest of its time slice, so the
  // threads that send and deliver get the CPU its next writes would take.
  if (backedUp && !onKernelThread()) std::this_thread::yield();
  return *tuple;
}

namespace {
// Waits for a remote write's completion; throws its error.
std::uint64_t awaitWrite(const std::function<void(WriteDone)>& start) {
  std::promise<std::pair<std::optional<Error>, std::uint64_t>> result;
  start([&result](const std::optional<Error>& error, std::uint64_t seqno) {
    result.set_value({error, seqno});
  });
  auto [error, seqno] = result.get_future().get();
  if (error) throw *error;
  return seqno;
}

void refuseOnKernelThread(const Kernel& kernel, const char* what) {
  if (kernel.onKernelThread()) {
    throw Error(ErrorCode::WouldDeadlock,
                std::string("a blocking ") + what +
                    " on the kernel thread (in a callback) would stop the kernel; use setAsync");
  }
}
}  // namespace

Tuple Kernel::set(PeisId owner, std::string_view key, std::string data,
                  const WriteOptions& options) {
  if (owner == id()) return set(key, std::move(data), options);
  refuseOnKernelThread(*this, "remote set");
  Tuple tuple;
  tuple.owner = owner;
  tuple.creator = id();
  tuple.key = std::string(key);
  tuple.data = data;
  tuple.mimetype = options.mimetype;
  tuple.encoding = options.encoding;
  tuple.ts_user = options.ts_user;
  tuple.seqno = awaitWrite([&](WriteDone done) {
    impl_->remoteWrite(wire::WriteOp::Set, owner, key, std::move(data), std::nullopt, options,
                       std::move(done));
  });
  return tuple;
}

void Kernel::setAsync(PeisId owner, std::string_view key, std::string data,
                      const WriteOptions& options, WriteDone done) {
  if (owner == id()) {
    std::optional<Error> error;
    std::uint64_t seqno = 0;
    try {
      seqno = set(key, std::move(data), options).seqno;
    } catch (const Error& e) {
      error = e;
    }
    if (done) post([done = std::move(done), error, seqno] { done(error, seqno); });
    return;
  }
  impl_->remoteWrite(wire::WriteOp::Set, owner, key, std::move(data), std::nullopt, options,
                     std::move(done));
}

Tuple Kernel::append(PeisId owner, std::string_view key, std::string_view data,
                     std::optional<std::uint64_t> ifSeqno) {
  if (owner == id()) return append(key, data, ifSeqno);
  refuseOnKernelThread(*this, "remote append");
  Tuple tuple;
  tuple.owner = owner;
  tuple.creator = id();
  tuple.key = std::string(key);
  tuple.seqno = awaitWrite([&](WriteDone done) {
    impl_->remoteWrite(wire::WriteOp::Append, owner, key, std::string(data), ifSeqno, {},
                       std::move(done));
  });
  return tuple;
}

bool Kernel::erase(PeisId owner, std::string_view key) {
  if (owner == id()) return erase(key);
  refuseOnKernelThread(*this, "remote erase");
  return awaitWrite([&](WriteDone done) {
           impl_->remoteWrite(wire::WriteOp::Erase, owner, key, "", std::nullopt, {},
                              std::move(done));
         }) != 0;
}

void Kernel::setWriteGate(WriteGate gate) {
  std::lock_guard lock(impl_->mu);
  impl_->writeGate = std::move(gate);
}

SubscriptionHandle Kernel::subscribe(const Pattern& pattern) {
  return impl_->mutate([&](TupleSpace&) { return impl_->replication.subscribe(pattern); });
}

bool Kernel::unsubscribe(SubscriptionHandle handle) {
  return impl_->mutate([&](TupleSpace&) { return impl_->replication.unsubscribe(handle); });
}

std::vector<PeerInfo> Kernel::peers() const {
  std::lock_guard lock(impl_->mu);
  if (impl_->peerSnapshot.empty()) return {PeerInfo{id(), impl_->name, 0, impl_->incarnation}};
  return impl_->peerSnapshot;
}

std::uint16_t Kernel::port() const {
  auto tuple = get(special::kPort);
  return tuple ? static_cast<std::uint16_t>(std::stoul(tuple->data)) : 0;
}

NetworkStats Kernel::networkStats() const {
  NetworkStats stats;
  auto read = [&] {
    if (!impl_->network) return;
    const auto& c = impl_->network->counters();
    stats = NetworkStats{c.framesIn,
                         c.framesOut,
                         c.malformedFrames,
                         c.garbagePeersDisconnected,
                         c.foreignEcologyRejected,
                         c.unroutable,
                         c.coalesced,
                         c.idCollisions,
                         c.malformedBeacons,
                         c.beaconsSuppressed};
    std::lock_guard lock(impl_->mu);
    stats.coalesced += impl_->replication.coalesced();
  };
  if (onKernelThread()) {
    read();
  } else {
    impl_->onKernelThreadAndWait(read);
  }
  return stats;
}

Tuple Kernel::append(std::string_view key, std::string_view data,
                     std::optional<std::uint64_t> ifSeqno, const WriteOptions& options) {
  auto tuple = impl_->mutate([&](TupleSpace& s) { return s.append(key, data, ifSeqno, options); });
  impl_->noteExpiry(*tuple);
  return *tuple;
}

bool Kernel::setDefault(std::string_view key, std::string data, const WriteOptions& options) {
  auto [tuple, wrote] = impl_->mutate([&](TupleSpace& s) {
    const auto before = s.seqno(s.self(), key);
    auto t = s.setDefault(key, std::move(data), options);
    return std::pair{t, t->seqno != before};
  });
  if (wrote) impl_->noteExpiry(*tuple);
  return wrote;
}

bool Kernel::erase(std::string_view key) {
  return impl_->mutate([&](TupleSpace& s) { return s.erase(key); });
}

std::optional<Tuple> Kernel::get(std::string_view ownKey) const { return get(impl_->id, ownKey); }

std::optional<Tuple> Kernel::get(PeisId owner, std::string_view key) const {
  std::lock_guard lock(impl_->mu);
  if (impl_->space.allKeysDirty() && key == special::kAllKeys && owner == impl_->id) {
    impl_->space.flushAllKeys();
    impl_->afterMutation();
  }
  auto tuple = impl_->space.get(owner, key);
  if (!tuple) return std::nullopt;
  return *tuple;
}

std::optional<Tuple> Kernel::get(PeisId owner, std::string_view key,
                                 std::chrono::milliseconds wait) const {
  if (wait.count() <= 0) return get(owner, key);
  if (onKernelThread()) {
    throw Error(ErrorCode::WouldDeadlock,
                "a blocking get on the kernel thread (in a callback) would stop the kernel; "
                "register a callback instead");
  }
  const auto deadline = deadlineAfter(std::chrono::steady_clock::now(), wait);
  // A remote value arrives by subscription: hold one while waiting.
  std::optional<SubscriptionHandle> subscription;
  if (owner != id()) {
    subscription = const_cast<Kernel*>(this)->subscribe(Pattern::exact(owner, key));
  }
  struct Unsubscribe {
    const Kernel* kernel;
    std::optional<SubscriptionHandle> handle;
    ~Unsubscribe() {
      if (handle) const_cast<Kernel*>(kernel)->unsubscribe(*handle);
    }
  } unsubscribe{this, subscription};
  std::unique_lock lock(impl_->mu);
  ++impl_->waiters;
  TuplePtr tuple;
  std::optional<TupleSpace::Withheld> withheld;  // a value that will not come
  impl_->changed.wait_until(lock, deadline, [&] {
    tuple = impl_->space.get(owner, key);
    if (!tuple) withheld = impl_->space.withheld(owner, key);
    return tuple != nullptr || withheld.has_value();
  });
  --impl_->waiters;
  lock.unlock();
  if (!tuple && withheld) throw Error(ErrorCode::TooLarge, withheld->reason(id()));
  if (!tuple) return std::nullopt;
  return *tuple;
}

std::optional<Tuple> Kernel::get(const FullName& name) const {
  return get(resolveOwner(name.owner), name.key);
}

std::vector<Tuple> Kernel::find(const Pattern& pattern) const {
  std::lock_guard lock(impl_->mu);
  std::vector<Tuple> found;
  for (const auto& tuple : impl_->space.find(pattern)) found.push_back(*tuple);
  return found;
}

PeisId Kernel::resolveOwner(std::string_view idOrName) const {
  if (auto number = parsePeisId(idOrName)) return *number;
  validateName(idOrName);
  std::lock_guard lock(impl_->mu);
  auto ids = impl_->space.peisNamed(idOrName);
  for (const auto& peer : impl_->peerSnapshot) {
    if (peer.name == idOrName) ids.push_back(peer.id);
  }
  if (impl_->name == idOrName) ids.push_back(impl_->id);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  if (ids.empty()) {
    throw Error(ErrorCode::NotFound, "no known PEIS is named '" + std::string(idOrName) + "'");
  }
  if (ids.size() > 1) {
    std::string list;
    for (auto id : ids) list += (list.empty() ? "" : ", ") + std::to_string(id);
    throw Error(ErrorCode::AmbiguousName, "the name '" + std::string(idOrName) +
                                              "' is ambiguous: it is carried by PEIS " + list +
                                              "; use an id instead");
  }
  return ids.front();
}

CallbackHandle Kernel::onChange(const Pattern& pattern, TupleCallback fn) {
  return impl_->mutate([&](TupleSpace& s) {
    return s.addCallback(pattern, kOnChange,
                         [fn = std::move(fn)](EventKind, const Tuple& t) { fn(t); });
  });
}

CallbackHandle Kernel::onDelete(const Pattern& pattern, TupleCallback fn) {
  return impl_->mutate([&](TupleSpace& s) {
    return s.addCallback(pattern, kOnDelete,
                         [fn = std::move(fn)](EventKind, const Tuple& t) { fn(t); });
  });
}

bool Kernel::removeCallback(CallbackHandle handle) {
  return impl_->mutate([&](TupleSpace& s) {
    impl_->replication.onIndirectRemoved(handle);
    return s.removeCallback(handle);
  });
}

void Kernel::declareMeta(std::string_view metaKey) {
  impl_->mutate([&](TupleSpace& s) {
    s.declareMeta(metaKey);
    return 0;
  });
}

void Kernel::setMeta(std::string_view metaKey, PeisId targetOwner, std::string_view targetKey) {
  impl_->mutate([&](TupleSpace& s) {
    return s.setMeta(metaKey, TupleRef{targetOwner, std::string(targetKey)});
  });
}

void Kernel::setMeta(PeisId metaOwner, std::string_view metaKey, PeisId targetOwner,
                     std::string_view targetKey) {
  if (metaOwner == impl_->id) return setMeta(metaKey, targetOwner, targetKey);
  validateKey(targetKey);
  WriteOptions options;
  options.mimetype = kMetaMimetype;
  set(metaOwner, metaKey, fullName(targetOwner, targetKey), options);
}

std::optional<TupleRef> Kernel::resolveMeta(PeisId owner, std::string_view metaKey) const {
  std::lock_guard lock(impl_->mu);
  return impl_->space.resolveMeta(owner, metaKey);
}

std::optional<Tuple> Kernel::getIndirect(PeisId owner, std::string_view metaKey) const {
  std::lock_guard lock(impl_->mu);
  auto tuple = impl_->space.getIndirect(owner, metaKey);
  if (!tuple) return std::nullopt;
  return *tuple;
}

Tuple Kernel::setIndirect(PeisId owner, std::string_view metaKey, std::string data,
                          const WriteOptions& options) {
  const auto target = resolveMeta(owner, metaKey);
  if (!target) {
    throw Error(ErrorCode::NotFound,
                "meta tuple " + fullName(owner, metaKey) + " does not point at a tuple");
  }
  return set(target->owner, target->key, std::move(data), options);
}

CallbackHandle Kernel::subscribeIndirect(PeisId owner, std::string_view metaKey, TupleCallback fn) {
  return impl_->mutate([&](TupleSpace& s) {
    const auto handle = s.addIndirectCallback(
        owner, metaKey, kOnChange, [fn = std::move(fn)](EventKind, const Tuple& t) { fn(t); });
    impl_->replication.trackIndirectMeta(handle, TupleRef{owner, std::string(metaKey)});
    return handle;
  });
}

void Kernel::post(std::function<void()> fn) {
  asio::post(impl_->io, [impl = impl_.get(), fn = std::move(fn)] {
    try {
      fn();
    } catch (const std::exception& e) {
      ++impl->callbackErrors;
      log::error(impl->id, std::string("a posted function threw: ") + e.what());
    } catch (...) {
      ++impl->callbackErrors;
      log::error(impl->id, "a posted function threw");
    }
  });
}

TimerHandle Kernel::after(std::chrono::milliseconds delay, std::function<void()> fn) {
  return impl_->addTimer(delay, std::chrono::milliseconds(0), std::move(fn));
}

TimerHandle Kernel::every(std::chrono::milliseconds period, std::function<void()> fn) {
  if (period.count() <= 0) {
    throw Error(ErrorCode::InvalidArgument, "a timer period must be positive");
  }
  return impl_->addTimer(period, period, std::move(fn));
}

bool Kernel::cancelTimer(TimerHandle handle) {
  std::shared_ptr<Impl::Timer> timer;
  {
    std::lock_guard lock(impl_->timersMu);
    auto it = impl_->timers.find(handle);
    if (it == impl_->timers.end()) return false;
    timer = it->second;
    impl_->timers.erase(it);
  }
  timer->active = false;
  asio::post(impl_->io, [timer] { timer->timer->cancel(); });
  return true;
}

bool Kernel::onKernelThread() const { return std::this_thread::get_id() == impl_->threadId; }

std::string Kernel::run() {
  auto signals = std::make_shared<asio::signal_set>(impl_->io, SIGINT, SIGTERM);
  signals->async_wait([impl = impl_.get()](const boost::system::error_code& ec, int signal) {
    if (!ec) impl->requestQuit(signal == SIGINT ? "SIGINT received" : "SIGTERM received");
  });
  std::unique_lock lock(impl_->quitMu);
  impl_->quitCv.wait(lock, [&] { return impl_->quitting; });
  asio::post(impl_->io, [signals] { signals->cancel(); });
  return impl_->quitReason;
}

bool Kernel::runFor(std::chrono::milliseconds limit) {
  std::unique_lock lock(impl_->quitMu);
  return impl_->quitCv.wait_until(lock, deadlineAfter(std::chrono::steady_clock::now(), limit),
                                  [&] { return impl_->quitting; });
}

void Kernel::quit(std::string reason) { impl_->requestQuit(std::move(reason)); }

bool Kernel::quitRequested() const {
  std::lock_guard lock(impl_->quitMu);
  return impl_->quitting;
}

std::uint64_t Kernel::callbackErrors() const { return impl_->callbackErrors; }

}  // namespace peis
