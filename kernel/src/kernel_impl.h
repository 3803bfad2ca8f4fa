// Kernel::Impl: the state behind the public Kernel, grouped by what guards
// it, and the kernel thread's work (docs/architecture.md, "Inside the
// kernel"). Its methods live in three files by concern:
//   kernel_impl.cpp    construction, the kernel.* tuples, quitting
//   kernel_pump.cpp    the pump: deliveries (drain), the outbox (flush),
//                      Subscribe retries, lease renewal, the expiry timer
//   kernel_network.cpp the network's events, remote writes, the write gate,
//                      id re-picks and the membership tuples
// The public API (kernel.cpp) locks `mu` through mutate() and reads.
#pragma once

#include <atomic>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <condition_variable>
#include <deque>
#include <future>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "adaptive_mutex.h"
#include "direct_send.h"
#include "net/link.h"
#include "net/network.h"
#include "peis/kernel.h"
#include "quiet_trim.h"
#include "remote_writes.h"
#include "replication.h"
#include "thread_annotations.h"
#include "timers.h"
#include "tuple_space.h"
#include "value_waiter.h"

namespace peis {

namespace security {
struct Credentials;
class Policy;
}  // namespace security

// The name a PEIS takes without --peis-name: the program name, cleaned.
std::string defaultPeisName(const Options& options, PeisId id);

struct Kernel::Impl {
  Impl(Options options, PeisId pickedId,
       std::shared_ptr<const security::Credentials> credentials = nullptr,
       std::shared_ptr<const security::Policy> policy = nullptr);

  // --- Fixed at construction (read from any thread) --------------------------
  const Options options;
  std::atomic<PeisId> id;  // changes only on an id re-pick (kernel thread, mu held)
  const std::string name;
  const std::uint64_t incarnation;
  // A secured ecology's credentials (null: an open ecology).
  const std::shared_ptr<const security::Credentials> credentials;
  const std::shared_ptr<const security::Policy> initialPolicy;  // of a secured PEIS
  boost::asio::io_context io;
  boost::asio::executor_work_guard<boost::asio::io_context::executor_type> work{io.get_executor()};
  std::thread thread;
  std::thread::id threadId;
  std::atomic<std::uint64_t> callbackErrors{0};

  // --- Guarded by the kernel lock `mu` ------------------------------------------
  // Application threads and the kernel thread meet here; every access to the
  // space and to replication holds it (the analysis checks it under clang).
  mutable AdaptiveMutex mu;
  // Signalled (mu held) on every mutation while `waiters` > 0: blocking get.
  mutable std::condition_variable_any changed;
  // Signalled (mu held) when the outbox has drained while writers wait for
  // it (awaitOutbox).
  std::condition_variable_any outboxDrained;
  TupleSpace space GUARDED_BY(mu);
  Replication replication GUARDED_BY(mu);
  bool drainScheduled GUARDED_BY(mu) = false;
  bool flushScheduled GUARDED_BY(mu) = false;
  bool retryArmed GUARDED_BY(mu) = false;      // retryTimer armed or posted
  bool networkStopped GUARDED_BY(mu) = false;  // no retry timer after stopNetwork
  mutable int waiters GUARDED_BY(mu) = 0;      // threads blocked in get(…, wait)
  // Threads blocked in waitForNext: served by afterMutation.
  mutable std::vector<std::shared_ptr<ValueWaiter>> valueWaiters GUARDED_BY(mu);
  int outboxWaiters GUARDED_BY(mu) = 0;  // writers in awaitOutbox
  // A writer's wait ran out without the outbox draining: a subscriber does
  // not keep up, and writers do not wait again until the outbox drained.
  bool outboxLagging GUARDED_BY(mu) = false;
  std::uint64_t outboxTaken GUARDED_BY(mu) = 0;       // entries flush took: progress
  std::vector<PeerInfo> peerSnapshot GUARDED_BY(mu);  // what peers() returns
  std::map<PeisId, PeisId> nextHops GUARDED_BY(mu);   // per peer, at the last topology change
  std::string publishedSubscribers GUARDED_BY(mu);
  WriteGate writeGate GUARDED_BY(mu);
  // Direct sends (docs/architecture.md, "Direct sends"): the link towards
  // each destination flush has served since the last topology change; whether flush has
  // taken entries it has not handed to the links yet (then nobody may send
  // around it); and when the last direct send happened, and whether a
  // message arrived since (a stream is left to flush's batches instead).
  std::map<PeisId, std::shared_ptr<net::Link>> directLinks GUARDED_BY(mu);
  std::size_t directBacklogLimit GUARDED_BY(mu) = 0;
  bool handingOff GUARDED_BY(mu) = false;
  std::chrono::steady_clock::time_point lastDirect GUARDED_BY(mu);
  bool receivedSinceDirect GUARDED_BY(mu) = true;

  // --- Kernel thread only (no lock) ----------------------------------------------
  std::unique_ptr<net::Network> network;
  RemoteWrites remoteWrites;
  boost::asio::steady_timer leaseTimer{io};
  boost::asio::steady_timer retryTimer{io};  // Replication::retryUnanswered
  boost::asio::steady_timer flushTimer{io};  // the next flush of a stream
  boost::asio::steady_timer expiryTimer{io};
  // Freed memory back to the system after a join, once data is quiet too.
  QuietTrim quietTrim{io, [this]() -> std::uint64_t {
                        if (!network) return 0;
                        const auto& c = network->counters();
                        return c.framesIn + c.framesOut +
                               c.directFramesOut.load(std::memory_order_relaxed);
                      }};
  Timestamp scheduledExpiry = kNoTime;
  std::vector<TupleSpace::Delivery> batch;  // deliveries taken, being run from batchNext
  std::size_t batchNext = 0;
  std::vector<TuplePtr> spentTuples;            // of deliveries that ran: back to the space
  std::vector<Replication::Outgoing> outgoing;  // flush's, memory reused
  std::vector<std::string> sentFrames;          // frames handed to links
  // Waiters onMessages served under the lock: woken once it let go.
  std::vector<std::shared_ptr<ValueWaiter>> wakeAfterUnlock;

  // --- Guarded by their own locks -------------------------------------------------
  TimerTable timers;
  mutable AdaptiveMutex quitMu;
  std::condition_variable_any quitCv;
  bool quitting GUARDED_BY(quitMu) = false;
  std::string quitReason GUARDED_BY(quitMu);

  // --- kernel_impl.cpp ---
  // Kernel::set and Kernel::publish of an own tuple: the stored tuple.
  TuplePtr setOwn(std::string_view key, std::string data, const WriteOptions& writeOptions)
      EXCLUDES(mu);
  // Kernel::publish: the same, returning only the seqno (the stored tuple
  // is read under the lock, no reference to it is taken).
  std::uint64_t publishOwn(std::string_view key, std::string data, const WriteOptions& writeOptions)
      EXCLUDES(mu);
  void publishSpecialTuples() EXCLUDES(mu);
  void requestQuit(std::string reason) EXCLUDES(quitMu);
  // A callback, timer function, posted function or completion threw.
  void reportThrown(std::string_view message);

  // Runs fn(space, replication) under the lock, then wakes the kernel
  // thread and blocked readers as needed.
  // What it queued for the network is sent from this thread, straight to
  // the links, when that keeps the rules (sendDirect).
  template <typename F>
  auto mutate(F&& fn) EXCLUDES(mu) {
    DirectSend direct;
    MutexLock lock(mu);
    auto result = fn(space, replication);
    afterMutation(&direct);
    lock.unlock();
    direct.send();
    return result;
  }

  // Runs `fn` on the kernel thread and waits for it (not from the kernel thread).
  template <typename F>
  void onKernelThreadAndWait(F&& fn) {
    std::promise<void> done;
    boost::asio::post(io, [&] {
      try {
        fn();
        done.set_value();
      } catch (...) {
        done.set_exception(std::current_exception());
      }
    });
    done.get_future().get();
  }

  // --- kernel_pump.cpp ---
  // Writer backpressure (docs/architecture.md, "Backpressure"): a writer
  // that finds kWriterWaitAbove bytes of updates waiting in the outbox waits
  // until they are down to kWriterResumeBelow, as long as some leave it
  // every kWriterProgressWait and at most kWriterMaxWait; if they do not, a
  // subscriber does not keep up: writers stop waiting (its updates
  // coalesce, as before) until the outbox drains.
  static constexpr std::size_t kWriterWaitAbove = 1u << 20;
  static constexpr std::size_t kWriterResumeBelow = 256u << 10;
  static constexpr std::chrono::milliseconds kWriterProgressWait{10};
  static constexpr std::chrono::milliseconds kWriterMaxWait{20};
  void awaitOutbox() EXCLUDES(mu);
  void noteOutboxDrained() REQUIRES(mu);
  // Posts drain / flush / the retry timer as the state needs; wakes
  // readers. With `direct`, what waits in the outbox may go into it instead
  // (sendDirect), for the caller to send once it has let go of mu.
  void afterMutation(DirectSend* direct = nullptr) REQUIRES(mu);
  // Hands each waitForNext waiter whose tuple has a new value that value;
  // wakes it now, or (`later`: a handler of received messages, which still
  // holds mu) puts it in wakeAfterUnlock.
  void serveValueWaiters(bool later) REQUIRES(mu);
  // Takes what waits in the outbox into `direct` when that keeps every rule
  // (see kernel_pump.cpp); true when nothing that could be sent is left
  // for flush.
  bool sendDirect(DirectSend& direct) REQUIRES(mu);
  // Forgets the links for direct sends: the topology changed (kernel
  // thread). flush() notes the link of each destination it serves.
  void forgetDirectLinks() REQUIRES(mu);
  // Runs deliveries now when on the kernel thread in a handler that
  // applied received messages (no post, no extra turn of the loop).
  bool drainInline = false;    // kernel thread only
  bool drainDeferred = false;  // kernel thread only: afterMutation left the drain to it
  bool flushDeferred = false;  // kernel thread only: and the flush
  void drain() EXCLUDES(mu);
  void flush() EXCLUDES(mu);
  void onWritable() EXCLUDES(mu);
  void armRetry() EXCLUDES(mu);
  void leaseLoop();
  // After a write of a tuple that expires: arm the expiry timer for it.
  void noteExpiry(const Tuple& tuple);
  void scheduleExpiry(Timestamp at);  // kernel thread

  // --- kernel_network.cpp ---
  void startNetwork() EXCLUDES(mu);
  // Fails pending remote writes, leaves the ecology (a Leave on every link)
  // and stops the network; `closed` runs once its links are closed.
  void stopNetwork(std::function<void()> closed) EXCLUDES(mu);
  void onMessages(std::span<wire::RoutedMessage> messages) EXCLUDES(mu);
  void onPeerUp(const net::PeerInfo& peer) EXCLUDES(mu);
  void onPeerDown(PeisId peer) EXCLUDES(mu);
  void onTopology() EXCLUDES(mu);
  PeisId repickId() EXCLUDES(mu);
  void holdWrite(const WriteGate& gate, PeisId source, wire::Write&& write);
  // Applies a remote write to an own tuple and schedules the expiry it may
  // have set (a --ttl from the writer).
  void applyWrite(PeisId source, const wire::Write& write) REQUIRES(mu);
  // Checks a write to another owner on the calling thread, then sends it
  // from the kernel thread; `done` completes it there.
  void remoteWrite(wire::WriteOp op, PeisId owner, std::string_view key, std::string data,
                   std::optional<std::uint64_t> ifSeqno, const WriteOptions& writeOptions,
                   WriteDone done);
  void snapshotPeers() REQUIRES(mu);
  void refreshMembershipTuples() REQUIRES(mu);
  void refreshSubscribersTuple() REQUIRES(mu);
};

}  // namespace peis
