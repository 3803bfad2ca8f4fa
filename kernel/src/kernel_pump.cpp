// The kernel's pump: what moves work from the state under `mu` to the kernel
// thread and out. `drain` runs queued deliveries (callbacks) with no lock
// held, `flush` hands the replication outbox to the network in bounded
// turns, and the timers renew leases, retry unanswered Subscribes and expire
// tuples (docs/architecture.md, "The kernel thread").
#include "kernel_impl.h"
#include "log.h"
#include "saturating_time.h"

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
// What may wait in the outbox for one destination whose link is congested
// before the link is closed (docs/protocol.md §13).
constexpr std::size_t kMaxWaitingBytes = 16u << 20;

}  // namespace

void Kernel::Impl::afterMutation(DirectSend* direct) {
  if (replication.guard().takePolicyChanged()) {
    // A new policy: what subscribers are sent is asked again, and PEIS
    // whose credentials it revokes are cut off (on the kernel thread).
    replication.reauthorize();
    asio::post(io, [this] {
      if (network) network->recheckIdentities();
    });
  }
  // A handler of received messages delivers and sends itself once it has
  // let go of the lock (Impl::onMessages); anything else posts.
  // (drainInline is the kernel thread's own: read only there.)
  const bool handlerRuns = std::this_thread::get_id() == threadId && drainInline;
  if (!flushScheduled && replication.outbox().hasReady() && !(direct && sendDirect(*direct))) {
    flushScheduled = true;
    if (handlerRuns) {
      flushDeferred = true;
    } else {
      asio::post(io, [this] { flush(); });
    }
  }
  if (!drainScheduled && (space.hasPendingDeliveries() || space.allKeysDirty())) {
    drainScheduled = true;
    if (handlerRuns) {
      drainDeferred = true;
    } else {
      asio::post(io, [this] { drain(); });
    }
  }
  if (waiters > 0) changed.notify_all();
  if (!valueWaiters.empty()) serveValueWaiters(handlerRuns);
  if (!retryArmed && replication.hasUnanswered()) {
    retryArmed = true;
    asio::post(io, [this] { armRetry(); });
  }
}

void Kernel::Impl::serveValueWaiters(bool later) {
  // Room first: a waiter served is always woken (no throw between).
  if (later) wakeAfterUnlock.reserve(wakeAfterUnlock.size() + valueWaiters.size());
  std::erase_if(valueWaiters, [&](const std::shared_ptr<ValueWaiter>& waiter) {
    mu.assertHeld();  // this function holds it (the analysis does not follow lambdas)
    auto tuple = space.get(waiter->owner, waiter->key);
    if (!tuple || tuple->seqno == waiter->seenSeqno) return false;
    waiter->fulfil(std::move(tuple));
    if (later) {
      wakeAfterUnlock.push_back(waiter);
    } else {
      waiter->wake();
    }
    return true;
  });
}

// A direct send hands the outbox's messages to the links from the thread
// that queued them, under `mu`, instead of waking the kernel thread to do it
// (a hand-off, a wake-up and a turn of its loop per message: most of a
// round trip's cost). The rules it keeps:
//  - order per destination: it takes from the outbox as flush does, and
//    never while flush holds taken entries it has not handed on
//    (handingOff); a link writes what it queued before what is sent now;
//  - backpressure per link: a destination whose link is congested, or
//    holds more than the congestion mark, is left in the outbox for flush
//    (which marks it and coalesces there) exactly as before;
//  - batching of streams: a writer that sends again within kDirectGap of
//    its last direct send, with nothing received meanwhile, is a stream:
//    its updates wait for flush's batches (one system call for many).
namespace {
constexpr std::chrono::microseconds kDirectGap{20};
}  // namespace

bool Kernel::Impl::sendDirect(DirectSend& direct) {
  if (directLinks.empty() || handingOff || networkStopped) return false;
  const auto now = std::chrono::steady_clock::now();
  if (!receivedSinceDirect && now - lastDirect < kDirectGap) return false;
  auto& outbox = replication.outbox();
  if (auto spare = DirectSend::spareFrames(); spare.capacity() > 0) {
    outbox.recycleFrames(std::move(spare));
  }
  thread_local std::vector<Replication::Outgoing> taken;  // memory reused
  taken.clear();
  outbox.take(
      taken, kMessagesPerTurn, kBytesPerTurn,
      [&](PeisId destination) {
        mu.assertHeld();
        const auto it = directLinks.find(destination);
        return it == directLinks.end() || !direct.admit(it->second, directBacklogLimit);
      },
      /*noteBlocked=*/false);
  if (taken.empty()) return false;
  lastDirect = now;
  receivedSinceDirect = false;
  direct.stamp(id, incarnation);
  for (auto& out : taken) {
    const auto destination = out.destination;
    direct.add(directLinks.at(destination).get(), std::move(out));
  }
  taken.clear();
  return !outbox.hasReady();
}

void Kernel::Impl::forgetDirectLinks() {
  directLinks.clear();  // flush notes them again as it sends (a join changes the topology often)
  if (network) directBacklogLimit = network->congestedAboveBytes();
}

void Kernel::Impl::awaitOutbox() {  // an application thread
  MutexLock lock(mu);
  if (outboxLagging) return;
  ++outboxWaiters;
  const auto deadline = std::chrono::steady_clock::now() + kWriterMaxWait;
  while (true) {
    const auto taken = outboxTaken;
    const bool drained = outboxDrained.wait_for(lock, kWriterProgressWait, [this] {
      mu.assertHeld();
      return replication.outboxBytes() < kWriterResumeBelow || networkStopped;
    });
    if (drained) break;
    // Nothing left the outbox for a while (its link is stalled), or the
    // wait is long already: a subscriber does not keep up.
    if (outboxTaken == taken || std::chrono::steady_clock::now() >= deadline) {
      outboxLagging = true;
      break;
    }
  }
  --outboxWaiters;
}

void Kernel::Impl::noteOutboxDrained() {
  if (replication.outboxBytes() >= kWriterResumeBelow) return;
  outboxLagging = false;
  if (outboxWaiters > 0) outboxDrained.notify_all();
}

void Kernel::Impl::armRetry() {  // kernel thread
  std::optional<std::chrono::steady_clock::time_point> at;
  {
    MutexLock lock(mu);
    at = replication.nextRetry();
    if (!at || networkStopped) {
      retryArmed = false;
      return;
    }
  }
  retryTimer.expires_at(*at);
  retryTimer.async_wait([this](const boost::system::error_code& ec) {
    MutexLock lock(mu);
    retryArmed = false;
    if (ec) return;
    replication.retryUnanswered(std::chrono::steady_clock::now());
    afterMutation();  // sends them, and arms the timer again if more are due
  });
}

void Kernel::Impl::drain() {  // kernel thread: deliveries taken from the space, run in turns
  // Each throwing callback is counted; the others for the event still run.
  const TupleSpace::Delivery* running = nullptr;
  const std::function<void(std::exception_ptr)> onError = [this,
                                                           &running](std::exception_ptr error) {
    const auto what = running->tuple() ? running->tuple()->fullName() : std::string("?");
    try {
      std::rethrow_exception(error);
    } catch (const std::exception& e) {
      reportThrown("a callback for " + what + " threw: " + e.what());
    } catch (...) {
      reportThrown("a callback for " + what + " threw");
    }
  };
  for (std::size_t ran = 0;; ++ran) {
    if (batchNext == batch.size()) {
      batch.clear();  // its memory goes to the space's queue with the swap
      batchNext = 0;
      // Destroyed after the lock below is let go (declared before it).
      TupleSpace::RemovedCallbacks removed;
      MutexLock lock(mu);
      space.recycle(spentTuples);      // their storage is reused for the next tuples
      space.deliveriesRan(removed);    // the callbacks removed meanwhile can go
      space.takeAllDeliveries(batch);  // a swap: one lock for all queued
      if (batch.empty()) {
        if (space.allKeysDirty()) {
          space.flushAllKeys();  // may queue deliveries of its own
          if (waiters > 0) changed.notify_all();
          if (!valueWaiters.empty()) serveValueWaiters(false);
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
    auto& delivery = batch[batchNext];
    running = &delivery;
    delivery.run(onError);
    if (delivery.tuple()) spentTuples.push_back(delivery.takeTuple());
    delivery = TupleSpace::Delivery();  // the callbacks' references go now
    ++batchNext;
  }
}

void Kernel::Impl::flush() {  // kernel thread
  outgoing.clear();
  std::vector<PeisId> cutOff;
  {
    MutexLock lock(mu);
    auto& outbox = replication.outbox();
    for (auto& frames : sentFrames) outbox.recycleFrames(std::move(frames));
    sentFrames.clear();
    // What waits for a destination whose link is congested stays in its
    // queue (coalescing there); every other destination is served.
    const bool more = outbox.take(
        outgoing, kMessagesPerTurn, kBytesPerTurn,
        [this](PeisId destination) { return network && network->blocked(destination); });
    for (const auto destination : outbox.blocked()) {
      if (outbox.waitingFor(destination) > kMaxWaitingBytes) {
        outbox.drop(destination);
        cutOff.push_back(destination);
      }
    }
    noteOutboxDrained();
    std::size_t messages = 0;
    for (const auto& out : outgoing) messages += out.frameCount > 0 ? out.frameCount : 1;
    // Until they are handed to the links, nobody sends around them.
    handingOff = !outgoing.empty();
    outboxTaken += outgoing.size();
    // The links of the destinations served here take the next direct sends.
    if (network && !networkStopped) {
      for (const auto& out : outgoing) {
        if (directLinks.count(out.destination)) continue;
        if (auto link = network->linkTowards(out.destination)) {
          directLinks.emplace(out.destination, std::move(link));
        }
      }
    }
    if (more) {
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
  if (!outgoing.empty()) {
    MutexLock lock(mu);
    handingOff = false;
  }
  outgoing.clear();  // drop the references to sent tuples now
  // A peer that takes in less than it is sent, for longer than coalescing
  // can absorb (messages that do not coalesce: the results of the writes it
  // keeps sending, say), is cut off.
  for (const auto destination : cutOff) {
    if (network) {
      network->cutOff(destination, "over " + std::to_string(kMaxWaitingBytes >> 20) +
                                       " MiB waited for it (it reads too slowly)");
    }
  }
}

void Kernel::Impl::onWritable() {  // kernel thread: a congested link drained
  {
    MutexLock lock(mu);
    replication.outbox().unblockAll();
  }
  flush();
}

void Kernel::Impl::leaseLoop() {  // kernel thread
  leaseTimer.expires_after(options.subscriptionLease / 3);
  leaseTimer.async_wait([this](const boost::system::error_code& ec) {
    if (ec) return;
    {
      MutexLock lock(mu);
      replication.renew();
      replication.outbox().trimSpares();  // a stream's spare entries, until it needs them again
      if (replication.expireLeases(std::chrono::steady_clock::now())) refreshSubscribersTuple();
      afterMutation();
    }
    leaseLoop();
  });
}

void Kernel::Impl::noteExpiry(const Tuple& tuple) {
  if (tuple.ts_expire == kNoTime) return;
  asio::post(io, [this, at = tuple.ts_expire] { scheduleExpiry(at); });
}

void Kernel::Impl::scheduleExpiry(Timestamp at) {  // kernel thread
  if (scheduledExpiry != kNoTime && scheduledExpiry <= at) return;
  scheduledExpiry = at;
  expiryTimer.expires_after(timerWait(at, systemNow()));  // far-off: fires early, re-armed
  expiryTimer.async_wait([this](const boost::system::error_code& ec) {
    if (ec) return;  // re-scheduled earlier or shutting down
    scheduledExpiry = kNoTime;
    const auto next = mutate([](TupleSpace& s, Replication&) {
      s.expire();
      return s.nextExpiry();
    });
    if (next != kNoTime) scheduleExpiry(next);
  });
}

}  // namespace peis
