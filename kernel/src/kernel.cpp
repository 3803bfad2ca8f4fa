// Kernel: the public API of a PEIS (peis/kernel.h). Each call locks the
// kernel lock through Impl::mutate (writes) or reads under it; remote writes
// and anything asynchronous go to the kernel thread (kernel_impl.h says what
// runs where and which lock guards what).
#include "peis/kernel.h"

#include <pthread.h>

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <random>

#include "kernel_impl.h"
#include "log.h"
#include "saturating_time.h"
#include "security/credentials.h"
#include "security/policy.h"

namespace peis {
namespace asio = boost::asio;

namespace {

// How long the destructor waits for the links to send what they hold.
constexpr std::chrono::milliseconds kLeaveGrace{500};

PeisId pickId(const Options& options) {
  if (options.id) return *options.id;
  std::random_device device;
  std::uniform_int_distribution<PeisId> pick(1000, kMaxPeisId);
  return pick(device);
}

}  // namespace

const char* versionString() { return "0.1.0"; }

Kernel::Kernel(Options options) {
  options.validate();
  std::shared_ptr<const security::Credentials> credentials;
  std::shared_ptr<const security::Policy> policy;
  if (!options.credentials.empty()) {
    auto loaded =
        std::make_shared<security::Credentials>(security::readCredentials(options.credentials));
    security::applyCredentials(*loaded, options, defaultPeisName(options, 0));
    credentials = std::move(loaded);
    policy = std::make_shared<const security::Policy>(options.policy.empty()
                                                          ? security::Policy::defaults()
                                                          : security::Policy::load(options.policy));
  }
  const auto id = pickId(options);
  impl_ = std::make_unique<Impl>(std::move(options), id, std::move(credentials), std::move(policy));
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
  log::info(id, "started as '" + impl_->name + "' (" + (impl_->credentials ? "secured " : "") +
                    "ecology " + impl_->options.ecology + ")");
}

namespace {
Options parseOrExit(int& argc, char** argv) {
  try {
    auto options = Options::fromArgs(argc, argv);
    if (options.help) {
      // stdio, not <iostream>: its static initialiser (the standard
      // streams and every facet of the classic locale) would run in every
      // PEIS, and fault in pages of a statically linked libstdc++ that a
      // PEIS otherwise never uses (docs/performance.md, "Memory per PEIS").
      const auto usage =
          "Usage: " + (options.programName.empty() ? "program" : options.programName) +
          " [options]\n\n" + Options::helpText();
      std::fputs(usage.c_str(), stdout);
      std::fflush(stdout);
      std::exit(0);
    }
    return options;
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: %s\n", argc > 0 && argv[0] ? argv[0] : "peis", e.what());
    std::exit(2);
  }
}
}  // namespace

Kernel::Kernel(int& argc, char** argv) : Kernel(parseOrExit(argc, argv)) {}

Kernel::~Kernel() {
  // The Leave frames and whatever the links still hold get a moment to go
  // out (a PEIS that quits cleanly vanishes from every table at once); a
  // link that takes longer is dropped with the io_context.
  auto closed = std::make_shared<std::promise<void>>();
  auto linksClosed = closed->get_future();
  impl_->onKernelThreadAndWait(
      [impl = impl_.get(), closed] { impl->stopNetwork([closed] { closed->set_value(); }); });
  linksClosed.wait_for(kLeaveGrace);
  impl_->timers.stopAll();
  impl_->work.reset();
  impl_->io.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
  // Threads still in waitForNext return null now, not at their deadline.
  MutexLock lock(impl_->mu);
  for (const auto& waiter : impl_->valueWaiters) {
    waiter->fulfil(nullptr);
    waiter->wake();
  }
  impl_->valueWaiters.clear();
}

PeisId Kernel::id() const { return impl_->id; }
std::string Kernel::name() const { return impl_->name; }
const Options& Kernel::options() const { return impl_->options; }

Tuple Kernel::set(std::string_view key, std::string data, const WriteOptions& options) {
  return *impl_->setOwn(key, std::move(data), options);
}

std::uint64_t Kernel::publish(std::string_view key, std::string data, const WriteOptions& options) {
  return impl_->publishOwn(key, std::move(data), options);
}

namespace {
// Waits for a remote write's completion; throws its error.
std::uint64_t awaitWrite(const std::function<void(WriteDone)>& start) {
  std::promise<std::pair<std::optional<Error>, std::uint64_t>> result;
  start([&result](const std::optional<Error>& error, std::uint64_t seqno) {
    // A deep copy: a copied std::runtime_error shares its message with the
    // original (a reference count inside libstdc++), which the kernel thread
    // then destroys while this thread reads it; ThreadSanitizer cannot see
    // that uninstrumented count and reports a race.
    std::optional<Error> own;
    if (error) own.emplace(error->code(), std::string(error->what()));
    result.set_value({std::move(own), seqno});
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
  MutexLock lock(impl_->mu);
  impl_->writeGate = std::move(gate);
}

SubscriptionHandle Kernel::subscribe(const Pattern& pattern) {
  return impl_->mutate([&](TupleSpace&, Replication& r) { return r.subscribe(pattern); });
}

bool Kernel::unsubscribe(SubscriptionHandle handle) {
  return impl_->mutate([&](TupleSpace&, Replication& r) { return r.unsubscribe(handle); });
}

std::vector<PeerInfo> Kernel::peers() const {
  MutexLock lock(impl_->mu);
  if (impl_->peerSnapshot.empty()) {
    return {PeerInfo{id(), impl_->name, 0, impl_->incarnation, impl_->options.tool}};
  }
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
                         c.framesOut + c.directFramesOut.load(std::memory_order_relaxed),
                         c.malformedFrames,
                         c.garbagePeersDisconnected,
                         c.foreignEcologyRejected,
                         c.unroutable,
                         c.coalesced,
                         c.idCollisions,
                         c.malformedBeacons,
                         c.beaconsSuppressed,
                         c.slowPeersDisconnected,
                         c.handshakeTimeouts,
                         c.connectionsRefused,
                         c.routesRefused,
                         c.heldFramesDropped,
                         c.authRefused,
                         c.unentitled,
                         c.directFramesOut.load(std::memory_order_relaxed)};
    MutexLock lock(impl_->mu);
    stats.coalesced += impl_->replication.coalesced();
  };
  if (onKernelThread()) {
    read();
  } else {
    impl_->onKernelThreadAndWait(read);
  }
  return stats;
}

AccessStats Kernel::accessStats() const {
  MutexLock lock(impl_->mu);
  return impl_->replication.guard().stats();
}

Tuple Kernel::append(std::string_view key, std::string_view data,
                     std::optional<std::uint64_t> ifSeqno, const WriteOptions& options) {
  auto tuple = impl_->mutate(
      [&](TupleSpace& s, Replication&) { return s.append(key, data, ifSeqno, options); });
  impl_->noteExpiry(*tuple);
  return *tuple;
}

bool Kernel::setDefault(std::string_view key, std::string data, const WriteOptions& options) {
  auto [tuple, wrote] = impl_->mutate([&](TupleSpace& s, Replication&) {
    const auto before = s.seqno(s.self(), key);
    auto t = s.setDefault(key, std::move(data), options);
    return std::pair{t, t->seqno != before};
  });
  if (wrote) impl_->noteExpiry(*tuple);
  return wrote;
}

bool Kernel::erase(std::string_view key) {
  return impl_->mutate([&](TupleSpace& s, Replication&) { return s.erase(key); });
}

std::optional<Tuple> Kernel::get(std::string_view ownKey) const { return get(impl_->id, ownKey); }

std::optional<Tuple> Kernel::get(PeisId owner, std::string_view key) const {
  MutexLock lock(impl_->mu);
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
  MutexLock lock(impl_->mu);
  ++impl_->waiters;
  TuplePtr tuple;
  std::optional<TupleSpace::Withheld> withheld;  // a value that will not come
  impl_->changed.wait_until(lock, deadline, [&] {
    impl_->mu.assertHeld();  // wait_until holds it again when it asks
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

std::shared_ptr<const Tuple> Kernel::waitForNext(PeisId owner, std::string_view key,
                                                 std::uint64_t seenSeqno,
                                                 std::chrono::milliseconds wait) const {
  const bool waits = wait.count() > 0;
  if (waits && onKernelThread()) {
    throw Error(ErrorCode::WouldDeadlock,
                "a blocking wait on the kernel thread (in a callback) would stop the kernel; "
                "register a callback instead");
  }
  const auto deadline = deadlineAfter(std::chrono::steady_clock::now(), wait);
  auto waiter = std::make_shared<ValueWaiter>();
  {
    MutexLock lock(impl_->mu);
    if (impl_->space.allKeysDirty() && key == special::kAllKeys && owner == impl_->id) {
      impl_->space.flushAllKeys();  // as get does: the list is brought up to date when read
      impl_->afterMutation();
    }
    auto tuple = impl_->space.get(owner, key);
    if (tuple && tuple->seqno != seenSeqno) return tuple;
    if (!waits) return nullptr;
    waiter->owner = owner;
    waiter->key = std::string(key);
    waiter->seenSeqno = seenSeqno;
    impl_->valueWaiters.push_back(waiter);
  }
  if (!waiter->waitUntil(deadline)) {
    MutexLock lock(impl_->mu);
    // Served while the deadline passed: the value is ours all the same.
    if (waiter->ready.load(std::memory_order_acquire) == 0) {
      std::erase(impl_->valueWaiters, waiter);
      return nullptr;
    }
  }
  return std::move(waiter->value);  // the kernel is done with it once ready
}

std::optional<Tuple> Kernel::get(const FullName& name) const {
  return get(resolveOwner(name.owner), name.key);
}

std::vector<Tuple> Kernel::find(const Pattern& pattern) const {
  MutexLock lock(impl_->mu);
  std::vector<Tuple> found;
  for (const auto& tuple : impl_->space.find(pattern)) found.push_back(*tuple);
  return found;
}

PeisId Kernel::resolveOwner(std::string_view idOrName) const {
  if (auto number = parsePeisId(idOrName)) return *number;
  validateName(idOrName);
  MutexLock lock(impl_->mu);
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
  return impl_->mutate([&](TupleSpace& s, Replication&) {
    return s.addValueCallback(pattern, kOnChange, std::move(fn));
  });
}

CallbackHandle Kernel::onDelete(const Pattern& pattern, TupleCallback fn) {
  return impl_->mutate([&](TupleSpace& s, Replication&) {
    return s.addValueCallback(pattern, kOnDelete, std::move(fn));
  });
}

CallbackHandle Kernel::onValue(const Pattern& pattern, TupleCallback fn) {
  return impl_->mutate([&](TupleSpace& s, Replication&) {
    return s.addValueCallbackWithHeld(pattern, std::move(fn));
  });
}

bool Kernel::removeCallback(CallbackHandle handle) {
  return impl_->mutate([&](TupleSpace& s, Replication& r) {
    r.onIndirectRemoved(handle);
    return s.removeCallback(handle);
  });
}

void Kernel::declareMeta(std::string_view metaKey) {
  impl_->mutate([&](TupleSpace& s, Replication&) {
    s.declareMeta(metaKey);
    return 0;
  });
}

void Kernel::setMeta(std::string_view metaKey, PeisId targetOwner, std::string_view targetKey) {
  impl_->mutate([&](TupleSpace& s, Replication&) {
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
  MutexLock lock(impl_->mu);
  return impl_->space.resolveMeta(owner, metaKey);
}

std::optional<Tuple> Kernel::getIndirect(PeisId owner, std::string_view metaKey) const {
  MutexLock lock(impl_->mu);
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
  return impl_->mutate([&](TupleSpace& s, Replication& r) {
    const auto handle = s.addIndirectCallback(
        owner, metaKey, kOnChange, [fn = std::move(fn)](EventKind, const Tuple& t) { fn(t); });
    r.trackIndirectMeta(handle, TupleRef{owner, std::string(metaKey)});
    return handle;
  });
}

void Kernel::post(std::function<void()> fn) {
  asio::post(impl_->io, [impl = impl_.get(), fn = std::move(fn)] {
    try {
      fn();
    } catch (const std::exception& e) {
      impl->reportThrown(std::string("a posted function threw: ") + e.what());
    } catch (...) {
      impl->reportThrown("a posted function threw");
    }
  });
}

TimerHandle Kernel::after(std::chrono::milliseconds delay, std::function<void()> fn) {
  return impl_->timers.add(delay, std::chrono::milliseconds(0), std::move(fn));
}

TimerHandle Kernel::every(std::chrono::milliseconds period, std::function<void()> fn) {
  if (period.count() <= 0) {
    throw Error(ErrorCode::InvalidArgument, "a timer period must be positive");
  }
  return impl_->timers.add(period, period, std::move(fn));
}

bool Kernel::cancelTimer(TimerHandle handle) { return impl_->timers.cancel(handle); }

bool Kernel::onKernelThread() const { return std::this_thread::get_id() == impl_->threadId; }

std::string Kernel::run() {
  auto signals = std::make_shared<asio::signal_set>(impl_->io, SIGINT, SIGTERM);
  signals->async_wait([impl = impl_.get()](const boost::system::error_code& ec, int signal) {
    if (!ec) impl->requestQuit(signal == SIGINT ? "SIGINT received" : "SIGTERM received");
  });
  std::string reason;
  {
    MutexLock lock(impl_->quitMu);
    impl_->quitCv.wait(lock, [&] {
      impl_->quitMu.assertHeld();
      return impl_->quitting;
    });
    reason = impl_->quitReason;
  }
  asio::post(impl_->io, [signals] { signals->cancel(); });
  return reason;
}

bool Kernel::runFor(std::chrono::milliseconds limit) {
  MutexLock lock(impl_->quitMu);
  return impl_->quitCv.wait_until(lock, deadlineAfter(std::chrono::steady_clock::now(), limit),
                                  [&] {
                                    impl_->quitMu.assertHeld();
                                    return impl_->quitting;
                                  });
}

void Kernel::quit(std::string reason) { impl_->requestQuit(std::move(reason)); }

bool Kernel::quitRequested() const {
  MutexLock lock(impl_->quitMu);
  return impl_->quitting;
}

std::uint64_t Kernel::callbackErrors() const { return impl_->callbackErrors; }

}  // namespace peis
