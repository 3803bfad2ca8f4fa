// Kernel: the one entry point of a PEIS. It owns the PEIS's tuple space and
// a kernel thread that runs callbacks and timers. Every public call is
// thread-safe; callbacks run on the kernel thread and may call the API.
//
//   peis::Kernel kernel(argc, argv);
//   kernel.set("temperature", "21.5");
//   kernel.onChange(peis::Pattern("light.*"), [](const peis::Tuple& t) {...});
//   kernel.run();  // until kernel.do-quit = yes, SIGINT or SIGTERM
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/error.h"
#include "peis/key.h"
#include "peis/options.h"
#include "peis/pattern.h"
#include "peis/tuple.h"

namespace peis {

using TupleCallback = std::function<void(const Tuple&)>;
using CallbackHandle = std::uint64_t;
using TimerHandle = std::uint64_t;
using SubscriptionHandle = std::uint64_t;
// Completion of a remote write: no error and the seqno the owner gave it, or
// the error (Unreachable, Timeout, Refused, or the owner's own error).
using WriteDone = std::function<void(const std::optional<Error>& error, std::uint64_t seqno)>;

// Decides one held remote write, exactly once, from any thread: no error
// applies it (the writer's set returns with the seqno), an error refuses it
// (the writer's set fails with that error). Later calls are ignored.
using WriteDecision = std::function<void(const std::optional<Error>& refusal)>;
// Sees every remote set of one of this PEIS's own tuples before it is
// applied. Returns false to let it apply now, or true to hold it and call
// `decide` later (e.g. once the device the PEIS stands for took the value).
// Runs on the kernel thread; it may call the Kernel.
using WriteGate =
    std::function<bool(const Tuple& requested, PeisId writer, const WriteDecision& decide)>;

// A PEIS this one can reach (directly or over several hops).
struct PeerInfo {
  PeisId id = 0;
  std::string name;
  int hops = 0;  // 0: this PEIS, 1: a direct link
  std::uint64_t incarnation = 0;
  bool tool = false;  // started with Options::tool (e.g. a `peis` command)
};

// Counters of the network layer (docs/protocol.md says what each counts).
struct NetworkStats {
  std::uint64_t framesIn = 0, framesOut = 0, malformedFrames = 0, garbagePeersDisconnected = 0,
                foreignEcologyRejected = 0, unroutable = 0, coalesced = 0, idCollisions = 0,
                malformedBeacons = 0, beaconsSuppressed = 0, slowPeersDisconnected = 0;
  // Limits hit (Options::limits, docs/security.md): connections closed at
  // the handshake deadline, connections refused over a cap, route entries
  // over --peis-max-routes, frames over the held limit.
  std::uint64_t handshakeTimeouts = 0, connectionsRefused = 0, routesRefused = 0,
                heldFramesDropped = 0;
  // Secured ecologies: links refused at the handshake (unauthenticated,
  // wrongly keyed, replayed, open and secured mixed; each logged with its
  // reason), and routes, identities or relayed frames that no PEIS proved
  // it was entitled to (dropped).
  std::uint64_t authRefused = 0, unentitled = 0;
  // Of framesOut: the frames a writing thread sent to its link itself (a
  // direct send, docs/architecture.md), sealed on a secured link.
  std::uint64_t directFramesOut = 0;
};

// Writes this PEIS refused as the owner (docs/security.md): over a remote
// writer's quota (Options::limits), to a kernel.* tuple only the kernel
// writes, or (secured ecologies) what its policy denies, subscriptions
// included. Also published as the kernel.denied tuple.
struct AccessStats {
  std::uint64_t quotaRefused = 0, kernelTupleRefused = 0;
  // Secured ecologies: writes and subscriptions the policy denied.
  std::uint64_t policyDenied = 0;
};

// The special tuples every PEIS publishes under "kernel.".
namespace special {
inline constexpr const char* kName = "kernel.name";
inline constexpr const char* kId = "kernel.id";
inline constexpr const char* kHostname = "kernel.hostname";
inline constexpr const char* kUser = "kernel.user";
inline constexpr const char* kVersion = "kernel.version";
inline constexpr const char* kAllKeys = "kernel.all-keys";
inline constexpr const char* kSubscribers = "kernel.subscribers";
inline constexpr const char* kLinks = "kernel.links";
inline constexpr const char* kDoQuit = "kernel.do-quit";
inline constexpr const char* kPeers = "kernel.peers";
inline constexpr const char* kPort = "kernel.port";
inline constexpr const char* kStarted = "kernel.started";
inline constexpr const char* kDenied = "kernel.denied";
inline constexpr const char* kPolicy = "kernel.policy";  // secured ecologies
}  // namespace special

const char* versionString();

class Kernel {
 public:
  explicit Kernel(Options options);
  // Parses the --peis-* flags (removing them from argv). With --help, prints
  // the flags and exits 0; on a bad flag, prints the error and exits 2.
  Kernel(int& argc, char** argv);
  Kernel(const Kernel&) = delete;
  Kernel& operator=(const Kernel&) = delete;
  ~Kernel();

  PeisId id() const;
  std::string name() const;
  const Options& options() const;

  // --- writes ---------------------------------------------------------------
  // Sets a tuple in this PEIS's namespace; returns it as stamped.
  Tuple set(std::string_view key, std::string data, const WriteOptions& options = {});
  // The same, returning only the seqno it was stamped with: no copy of the
  // tuple (of its data) is made for the caller. For publishers of streams
  // and of big values.
  std::uint64_t publish(std::string_view key, std::string data, const WriteOptions& options = {});
  // Sets a tuple of any owner and returns once the owner accepted it (the
  // returned tuple carries the owner's seqno). Throws Error(Unreachable /
  // Timeout / the owner's error). On the kernel thread: Error(WouldDeadlock),
  // use setAsync there.
  Tuple set(PeisId owner, std::string_view key, std::string data, const WriteOptions& options = {});
  // The same without waiting; `done` runs on the kernel thread.
  void setAsync(PeisId owner, std::string_view key, std::string data,
                const WriteOptions& options = {}, WriteDone done = {});
  // Appends to / deletes another owner's tuple, waiting for the owner.
  Tuple append(PeisId owner, std::string_view key, std::string_view data,
               std::optional<std::uint64_t> ifSeqno = std::nullopt);
  bool erase(PeisId owner, std::string_view key);
  // Appends to an own tuple atomically; with `ifSeqno`, only if the tuple's
  // seqno is still that number (else Error(Conflict)).
  Tuple append(std::string_view key, std::string_view data,
               std::optional<std::uint64_t> ifSeqno = std::nullopt,
               const WriteOptions& options = {});
  // Sets an own tuple only if it has no value; true when it wrote.
  bool setDefault(std::string_view key, std::string data, const WriteOptions& options = {});
  // Deletes an own tuple; false when it did not exist.
  bool erase(std::string_view key);

  // --- reads (local, never a network round trip) -----------------------------
  std::optional<Tuple> get(std::string_view ownKey) const;
  std::optional<Tuple> get(PeisId owner, std::string_view key) const;
  // Waits up to `wait` for the tuple to have a value. Not allowed on the
  // kernel thread (Error(WouldDeadlock)): use a callback there.
  std::optional<Tuple> get(PeisId owner, std::string_view key,
                           std::chrono::milliseconds wait) const;
  // Waits up to `wait` for the tuple to hold a value whose seqno is not
  // `seenSeqno` (0: any value), and returns it; null at the deadline. For
  // a thread that waits for an answer (a request's reply, the next frame):
  // the value is the stored one, shared and immutable (its data is not
  // copied), and the thread is woken by a futex the moment the kernel
  // stored it (no lock to take again). Values in between may be skipped:
  // it returns the newest. A remote tuple's values arrive only while this
  // PEIS subscribes to it (subscribe). Not allowed on the kernel thread
  // (Error(WouldDeadlock)) unless `wait` is 0: use a callback there.
  // `seenSeqno` is compared for equality only: after a remote owner
  // restarts, a new value that happens to carry the seqno seen waits for
  // the next. Destroying the Kernel returns null to threads still waiting.
  std::shared_ptr<const Tuple> waitForNext(PeisId owner, std::string_view key,
                                           std::uint64_t seenSeqno,
                                           std::chrono::milliseconds wait) const;
  // "OWNER.KEY" with OWNER an id or a PEIS name.
  std::optional<Tuple> get(const FullName& name) const;
  std::vector<Tuple> find(const Pattern& pattern) const;
  // An id or a PEIS name -> id; Error(NotFound / AmbiguousName) otherwise.
  PeisId resolveOwner(std::string_view idOrName) const;

  // --- subscriptions: interest that makes owners push their changes here ---
  // Owners matching the pattern (one owner, or any, including PEIS that
  // join later) send their matching tuples now and every change after.
  SubscriptionHandle subscribe(const Pattern& pattern);
  bool unsubscribe(SubscriptionHandle handle);

  // Holds remote sets of own tuples for a decision (see WriteGate); an empty
  // function removes the gate. Appends and erases are never held.
  void setWriteGate(WriteGate gate);

  // --- the ecology ------------------------------------------------------------
  // Every PEIS reachable now, this one included (hops 0).
  std::vector<PeerInfo> peers() const;
  // Waits up to `timeout` until a PEIS of that name (or id) is reachable and
  // returns its id; nothing at the deadline. AmbiguousName when several
  // reachable PEIS carry the name, InvalidName for a malformed one,
  // WouldDeadlock on the kernel thread (unless timeout is 0).
  std::optional<PeisId> waitForPeer(std::string_view idOrName,
                                    std::chrono::milliseconds timeout) const;
  // The TCP port this PEIS listens on (0 without network).
  std::uint16_t port() const;
  NetworkStats networkStats() const;
  AccessStats accessStats() const;

  // --- callbacks ----------------------------------------------------------------
  CallbackHandle onChange(const Pattern& pattern, TupleCallback fn);
  CallbackHandle onDelete(const Pattern& pattern, TupleCallback fn);
  // onChange that also starts with every matching tuple held now (each
  // once, as a change, before any later change): no value is missed
  // however the callback and the tuples' arrival interleave. onChange alone
  // fires only on a change: a value already cached (by an earlier
  // subscription, or brought again with the same seqno after its owner was
  // unreachable for a while) never reaches a callback registered after it.
  CallbackHandle onValue(const Pattern& pattern, TupleCallback fn);
  // After this returns the callback is not started again.
  bool removeCallback(CallbackHandle handle);

  // --- meta tuples ----------------------------------------------------------------
  // Creates an own meta tuple pointing nowhere, unless it exists.
  void declareMeta(std::string_view metaKey);
  // Points own meta tuple `metaKey` at (targetOwner, targetKey).
  void setMeta(std::string_view metaKey, PeisId targetOwner, std::string_view targetKey);
  // Points another PEIS's meta tuple (through its owner).
  void setMeta(PeisId metaOwner, std::string_view metaKey, PeisId targetOwner,
               std::string_view targetKey);
  std::optional<TupleRef> resolveMeta(PeisId owner, std::string_view metaKey) const;
  std::optional<Tuple> getIndirect(PeisId owner, std::string_view metaKey) const;
  // Writes whatever the meta tuple points to; Error(NotFound) if nothing.
  Tuple setIndirect(PeisId owner, std::string_view metaKey, std::string data,
                    const WriteOptions& options = {});
  // Calls `fn` with every change of whatever the meta tuple points to, and
  // with the new target's current value when it is re-pointed. Subscribes
  // to the meta tuple and to its current target when they are remote.
  CallbackHandle subscribeIndirect(PeisId owner, std::string_view metaKey, TupleCallback fn);

  // --- the kernel thread -------------------------------------------------------------
  // Runs `fn` on the kernel thread, after the calls already queued.
  void post(std::function<void()> fn);
  TimerHandle after(std::chrono::milliseconds delay, std::function<void()> fn);
  TimerHandle every(std::chrono::milliseconds period, std::function<void()> fn);
  bool cancelTimer(TimerHandle handle);
  bool onKernelThread() const;

  // --- life cycle ---------------------------------------------------------------------
  // Blocks until quit() is called, kernel.do-quit is set to "yes", or the
  // process gets SIGINT / SIGTERM. Returns the reason as text.
  std::string run();
  // run() with a deadline; false if it did not quit in time.
  bool runFor(std::chrono::milliseconds limit);
  void quit(std::string reason = "quit() called");
  bool quitRequested() const;
  // Callback exceptions caught and logged so far.
  std::uint64_t callbackErrors() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis
