// Kernel: glues the TupleSpace to one kernel thread (Boost.Asio io_context).
// Public calls lock the space, mutate it and queue deliveries; the kernel
// thread runs the deliveries with no lock held, so callbacks may call the API.
#include "peis/kernel.h"

#include <pwd.h>
#include <unistd.h>

#include <atomic>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include "log.h"
#include "peis/error.h"
#include "tuple_space.h"

namespace peis {
namespace asio = boost::asio;

namespace {

constexpr int kDeliveriesPerTurn = 256;  // then let timers and posts run

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

std::string userName() {
  if (const char* user = std::getenv("USER"); user && *user) return user;
  if (const passwd* entry = getpwuid(getuid())) return entry->pw_name;
  return "unknown";
}

}  // namespace

std::string metaInputKey(std::string_view input) { return "mi-" + std::string(input); }
const char* versionString() { return "0.1.0"; }

struct Kernel::Impl {
  Options options;
  PeisId id;
  std::string name;
  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> work{io.get_executor()};
  std::thread thread;
  std::thread::id threadId;

  mutable std::mutex mu;  // guards everything below down to `waiters`
  mutable std::condition_variable changed;
  TupleSpace space;
  bool drainScheduled = false;
  mutable int waiters = 0;

  std::mutex timersMu;
  struct Timer {
    std::shared_ptr<asio::steady_timer> timer;
    std::function<void()> fn;
    std::chrono::milliseconds period{0};
    std::atomic<bool> active{true};
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
        space(id, systemNow, SpaceLimits{options.maxDataBytes}) {}

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
    if (!drainScheduled && (space.hasPendingDeliveries() || space.allKeysDirty())) {
      drainScheduled = true;
      asio::post(io, [this] { drain(); });
    }
    if (waiters > 0) changed.notify_all();
  }

  void drain() {
    for (int turn = 0; turn < kDeliveriesPerTurn; ++turn) {
      std::optional<TupleSpace::Delivery> delivery;
      {
        std::lock_guard lock(mu);
        delivery = space.nextDelivery();
        if (!delivery) {
          if (space.allKeysDirty()) {
            space.flushAllKeys();
            if (waiters > 0) changed.notify_all();
            continue;
          }
          drainScheduled = false;
          return;
        }
      }
      try {
        delivery->run();
      } catch (const std::exception& e) {
        ++callbackErrors;
        log::error(id, "a callback for " + delivery->tuple()->fullName() + " threw: " + e.what());
      } catch (...) {
        ++callbackErrors;
        log::error(id, "a callback for " + delivery->tuple()->fullName() + " threw");
      }
    }
    asio::post(io, [this] { drain(); });  // more to do: yield to timers first
  }

  void noteExpiry(const Tuple& tuple) {
    if (tuple.ts_expire == kNoTime) return;
    asio::post(io, [this, at = tuple.ts_expire] { scheduleExpiry(at); });
  }

  void scheduleExpiry(Timestamp at) {  // kernel thread
    if (scheduledExpiry != kNoTime && scheduledExpiry <= at) return;
    scheduledExpiry = at;
    expiryTimer.expires_after(at - systemNow());
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
    timer->timer->expires_after(delay);
    timer->timer->async_wait([this, timer](const boost::system::error_code& ec) {
      if (ec || !timer->active) return;
      try {
        timer->fn();
      } catch (const std::exception& e) {
        ++callbackErrors;
        log::error(id, std::string("a timer callback threw: ") + e.what());
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
      timers.emplace(handle, timer);
    }
    asio::post(io, [this, timer, delay] { startTimer(timer, delay); });
    return handle;
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
  impl_->thread = std::thread([impl = impl_.get()] { impl->io.run(); });
  impl_->threadId = impl_->thread.get_id();
  try {
    impl_->publishSpecialTuples();
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
  auto tuple = impl_->mutate([&](TupleSpace& s) { return s.set(key, std::move(data), options); });
  impl_->noteExpiry(*tuple);
  return *tuple;
}

Tuple Kernel::set(PeisId owner, std::string_view key, std::string data,
                  const WriteOptions& options) {
  if (owner == impl_->id) return set(key, std::move(data), options);
  validateKey(key);
  throw Error(ErrorCode::Unreachable, "cannot write " + fullName(owner, key) + ": PEIS " +
                                          std::to_string(owner) +
                                          " is not reachable (no link to it)");
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
  const auto deadline = std::chrono::steady_clock::now() + wait;
  std::unique_lock lock(impl_->mu);
  ++impl_->waiters;
  TuplePtr tuple;
  impl_->changed.wait_until(lock, deadline, [&] {
    tuple = impl_->space.get(owner, key);
    return tuple != nullptr;
  });
  --impl_->waiters;
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
  std::lock_guard lock(impl_->mu);
  return impl_->space.resolveOwner(idOrName);
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
  return impl_->mutate([&](TupleSpace& s) { return s.removeCallback(handle); });
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
    return s.addIndirectCallback(owner, metaKey, kOnChange,
                                 [fn = std::move(fn)](EventKind, const Tuple& t) { fn(t); });
  });
}

void Kernel::post(std::function<void()> fn) {
  asio::post(impl_->io, [impl = impl_.get(), fn = std::move(fn)] {
    try {
      fn();
    } catch (const std::exception& e) {
      ++impl->callbackErrors;
      log::error(impl->id, std::string("a posted function threw: ") + e.what());
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
  return impl_->quitCv.wait_for(lock, limit, [&] { return impl_->quitting; });
}

void Kernel::quit(std::string reason) { impl_->requestQuit(std::move(reason)); }

bool Kernel::quitRequested() const {
  std::lock_guard lock(impl_->quitMu);
  return impl_->quitting;
}

std::uint64_t Kernel::callbackErrors() const { return impl_->callbackErrors; }

}  // namespace peis
