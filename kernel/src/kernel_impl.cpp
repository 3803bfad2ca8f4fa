// Kernel::Impl: construction, the kernel.* tuples published at start, and
// quit requests. See kernel_impl.h for how the state is guarded.
#include "kernel_impl.h"

#include <pwd.h>
#include <unistd.h>

#include <cstdlib>

#include "log.h"
#include "security/policy.h"

namespace peis {

std::string defaultPeisName(const Options& options, PeisId id) {
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

namespace {

std::string pickName(const Options& options, PeisId id) {
  return options.name.empty() ? defaultPeisName(options, id) : options.name;
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

Kernel::Impl::Impl(Options opts, PeisId pickedId,
                   std::shared_ptr<const security::Credentials> secured,
                   std::shared_ptr<const security::Policy> policy)
    : options(std::move(opts)),
      id(pickedId),
      name(pickName(options, pickedId)),
      incarnation(static_cast<std::uint64_t>(systemNow().time_since_epoch().count())),
      credentials(std::move(secured)),
      initialPolicy(std::move(policy)),
      space(pickedId, systemNow, SpaceLimits{options.maxDataBytes}),
      replication(space, incarnation, options.subscriptionLease, options.limits),
      remoteWrites(io,
                   [this](std::string_view what) {
                     reportThrown(std::string("a write completion threw: ") + std::string(what));
                   }),
      timers(io, [this](std::string_view what) { reportThrown(what); }) {
  // The space calls these with mu held (from inside its own methods).
  space.setObserver([this](EventKind kind, const TuplePtr& t) {
    mu.assertHeld();
    replication.onLocalEvent(kind, t);
  });
  space.setNameSource([this](std::string_view wanted) {
    mu.assertHeld();
    std::vector<PeisId> ids;
    for (const auto& peer : peerSnapshot) {
      if (peer.name == wanted) ids.push_back(peer.id);
    }
    return ids;
  });
  space.setRetargetObserver(
      [this](CallbackId id, const std::optional<TupleRef>&, const std::optional<TupleRef>& to) {
        mu.assertHeld();
        replication.onRetarget(id, to);
      });
}

void Kernel::Impl::reportThrown(std::string_view message) {
  ++callbackErrors;
  log::error(id, message);
}

void Kernel::Impl::requestQuit(std::string reason) {
  {
    MutexLock lock(quitMu);
    if (quitting) return;
    quitting = true;
    quitReason = std::move(reason);
    log::info(id, "quitting: " + quitReason);
  }
  quitCv.notify_all();
}

void Kernel::Impl::publishSpecialTuples() {
  mutate([&](TupleSpace& s, Replication&) {
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
    s.setKernelTuple(special::kDenied, "0 denied");
    if (initialPolicy) s.setKernelTuple(special::kPolicy, initialPolicy->text());
    s.addCallback(Pattern::exact(id, special::kDoQuit), kOnChange,
                  [this](EventKind, const Tuple& t) {
                    if (t.data == "yes") {
                      requestQuit("kernel.do-quit set to yes by PEIS " + std::to_string(t.creator));
                    }
                  });
    for (const auto& [key, value] : options.setTuples) s.set(key, value);
    s.flushAllKeys();
    return 0;
  });
}

TuplePtr Kernel::Impl::setOwn(std::string_view key, std::string data,
                              const WriteOptions& writeOptions) {
  bool backedUp = false;
  auto tuple = mutate([&](TupleSpace& s, Replication& r) {
    auto stored = s.set(key, std::move(data), writeOptions);
    backedUp = r.outboxBytes() >= kWriterWaitAbove;
    return stored;
  });
  noteExpiry(*tuple);
  // A writer that outruns its subscribers (updates have started to wait in
  // the outbox) waits, a bounded time, for them to catch up, rather than
  // produce values that would be coalesced (awaitOutbox).
  if (backedUp && std::this_thread::get_id() != threadId) awaitOutbox();
  return tuple;
}

std::uint64_t Kernel::Impl::publishOwn(std::string_view key, std::string data,
                                       const WriteOptions& writeOptions) {
  bool backedUp = false;
  Timestamp expire = kNoTime;
  const auto seqno = mutate([&](TupleSpace& s, Replication& r) {
    const Tuple& stored = s.write(key, std::move(data), writeOptions);
    expire = stored.ts_expire;
    backedUp = r.outboxBytes() >= kWriterWaitAbove;
    return stored.seqno;
  });
  if (expire != kNoTime) boost::asio::post(io, [this, expire] { scheduleExpiry(expire); });
  if (backedUp && std::this_thread::get_id() != threadId) awaitOutbox();
  return seqno;
}

}  // namespace peis
