// TupleSpace: the tuples one PEIS holds (its own namespace and its cache of
// other owners' tuples), with stamping, expiry, append, callbacks and meta
// tuple resolution. No sockets, no threads, the clock is injected: every
// behaviour is deterministic and testable alone. Not thread-safe; the Kernel
// serialises access.
//
// Callbacks are matched when an event happens and run later, in order, by
// dispatch() (or by the Kernel via nextDelivery()). A callback may therefore
// call back into the space without re-entering a running callback.
//
// Another owner's seqnos start again at 1 when it restarts, so every
// comparison of its seqnos is one of (incarnation, seqno): a new incarnation
// is accepted at once, in the cache and by indirect callbacks alike.
#pragma once

#include <boost/container/small_vector.hpp>
#include <cstdint>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/pattern.h"
#include "peis/tuple.h"

namespace peis {

using Clock = std::function<Timestamp()>;
using TuplePtr = std::shared_ptr<const Tuple>;

enum class EventKind : std::uint8_t { Changed = 1, Deleted = 2 };
enum EventMask : unsigned { kOnChange = 1, kOnDelete = 2, kOnAny = 3 };

using Callback = std::function<void(EventKind, const Tuple&)>;
using ValueCallback = std::function<void(const Tuple&)>;
using CallbackId = std::uint64_t;

struct SpaceLimits {
  std::size_t maxDataBytes = kDefaultMaxDataBytes;
};

class TupleSpace {
  struct Entry;
  struct Indirect;

 public:
  TupleSpace(PeisId self, Clock clock, SpaceLimits limits = {});
  TupleSpace(const TupleSpace&) = delete;
  TupleSpace& operator=(const TupleSpace&) = delete;
  ~TupleSpace();

  PeisId self() const { return self_; }
  // Moves every own tuple to a new owner id (after an id collision).
  void changeSelf(PeisId newId);
  const SpaceLimits& limits() const { return limits_; }

  // --- writes the owner accepts (owner = self) -----------------------------
  // Stamps ts_write and the next seqno, stores, queues change events.
  // `creator` 0 means self. Throws Error(InvalidKey / TooLarge).
  TuplePtr set(std::string_view key, std::string data, const WriteOptions& options = {},
               PeisId creator = 0);
  // The same, returning the stored tuple itself rather than a reference
  // to share (no reference count touched): valid only until the space is
  // changed again, so read under the same serialisation.
  const Tuple& write(std::string_view key, std::string data, const WriteOptions& options = {},
                     PeisId creator = 0);
  // The kernel's own kernel.* tuples: like set(), exempt from the data limit.
  TuplePtr setKernelTuple(std::string_view key, std::string data);
  // Appends `data` to the current value atomically; creates the tuple when
  // absent. With `ifSeqno`, fails with Error(Conflict) unless the current
  // seqno (0 when absent) is still that number.
  TuplePtr append(std::string_view key, std::string_view data,
                  std::optional<std::uint64_t> ifSeqno = std::nullopt,
                  const WriteOptions& options = {}, PeisId creator = 0);
  // Writes only when the key has no value; returns the value now held.
  TuplePtr setDefault(std::string_view key, std::string data, const WriteOptions& options = {});
  // Deletes an own tuple; false when it was absent.
  bool erase(std::string_view key);

  // --- tuples of other owners, already stamped by them ---------------------
  // The incarnation (start) of another owner that its cached tuples belong
  // to; 0 while none is known.
  std::uint64_t incarnationOf(PeisId owner) const;
  // Records an owner's incarnation. A newer one than known (the owner
  // restarted) first drops everything cached of the older one (forgetOwner).
  // False for an older one: a message of a previous life, to be dropped. 0
  // means "the one known" (true).
  bool noteIncarnation(PeisId owner, std::uint64_t incarnation);
  // Stores `tuple` of owner incarnation `incarnation` (0: the one known)
  // unless the cache holds the same or a newer value for it; returns whether
  // it was stored.
  bool accept(const Tuple& tuple, std::uint64_t incarnation = 0) {
    return accept(Tuple(tuple), incarnation);
  }
  bool accept(Tuple&& tuple, std::uint64_t incarnation = 0);
  // Removes a cached tuple deleted by its owner at `seqno`.
  bool acceptDelete(PeisId owner, std::string_view key, std::uint64_t seqno,
                    std::uint64_t incarnation = 0);

  // A tuple of another owner whose value is over a data limit (this PEIS's
  // or a relay's): only what is known without the data.
  struct Withheld {
    Tuple tuple;  // every field but the data (empty)
    std::uint32_t dataBytes = 0;
    PeisId limitedBy = 0;     // the PEIS whose limit the value is over
    std::uint32_t limit = 0;  // that limit
    // "OWNER.KEY is N bytes: too large for ... --peis-max-data ..."
    std::string reason(PeisId self) const;
  };
  // Records that the value of (owner, key) at the given seqno is withheld;
  // like accept, only when newer than what is held. A cached older value is
  // removed (a delete event): it is no longer the owner's value.
  bool acceptWithheld(Withheld&& withheld, std::uint64_t incarnation = 0);
  // The withheld record of (owner, key), unless a value is cached or it expired.
  std::optional<Withheld> withheld(PeisId owner, std::string_view key) const;
  // The live withheld records that match `pattern`.
  std::vector<Withheld> findWithheld(const Pattern& pattern) const;
  // Forgets the withheld records of `owner` that a PEIS on the way made
  // (limited by neither the owner nor this PEIS): the value may pass now.
  std::size_t forgetRelayWithheld(PeisId owner);

  // Drops every cached tuple of another owner (it restarted or is gone),
  // queueing delete events; returns how many.
  std::size_t forgetOwner(PeisId owner);

  // --- observers (called synchronously, inside the mutating call) ----------
  // Every change or delete of any tuple, before callbacks are matched.
  using Observer = std::function<void(EventKind, const TuplePtr&)>;
  void setObserver(Observer observer) { observer_ = std::move(observer); }
  // An indirect callback's target changed (from, to).
  using RetargetObserver = std::function<void(CallbackId, const std::optional<TupleRef>&,
                                              const std::optional<TupleRef>&)>;
  void setRetargetObserver(RetargetObserver observer) { retargetObserver_ = std::move(observer); }
  // More names than the cached kernel.name tuples (e.g. learnt from routes).
  using NameSource = std::function<std::vector<PeisId>(std::string_view)>;
  void setNameSource(NameSource names) { names_ = std::move(names); }
  // Re-resolves every indirect callback (after the known names changed).
  void refreshIndirects();

  // --- reads ----------------------------------------------------------------
  TuplePtr get(PeisId owner, std::string_view key) const;
  std::vector<TuplePtr> find(const Pattern& pattern) const;
  // Current seqno of a key (0 when never written).
  std::uint64_t seqno(PeisId owner, std::string_view key) const;
  std::vector<std::string> keysOf(PeisId owner) const;
  std::size_t size() const { return tuples_.size(); }
  // Ids of the PEIS whose cached `kernel.name` equals `name`.
  std::vector<PeisId> peisNamed(std::string_view name) const;
  // Resolves an owner written as an id or a name. Throws
  // Error(InvalidName / AmbiguousName listing the candidates / NotFound).
  PeisId resolveOwner(std::string_view owner) const;

  // --- expiry ---------------------------------------------------------------
  // Removes every tuple expired at clock(); queues delete events.
  std::size_t expire();
  // Earliest ts_expire among held tuples, kNoTime when none.
  Timestamp nextExpiry() const;

  // --- meta tuples ----------------------------------------------------------
  // Creates an own meta tuple pointing nowhere, unless it exists.
  void declareMeta(std::string_view metaKey);
  // Points an own meta tuple at (owner, key).
  TuplePtr setMeta(std::string_view metaKey, const TupleRef& target);
  // What a meta tuple points to, when it exists and points somewhere.
  std::optional<TupleRef> resolveMeta(PeisId owner, std::string_view metaKey) const;
  TuplePtr getIndirect(PeisId owner, std::string_view metaKey) const;

  // --- callbacks --------------------------------------------------------------
  CallbackId addCallback(const Pattern& pattern, unsigned mask, Callback fn);
  // The same for a function of the tuple alone (called without a wrapper).
  CallbackId addValueCallback(const Pattern& pattern, unsigned mask, ValueCallback fn);
  // The same, and queues at once a change event for this callback alone
  // with every matching tuple held now: under the lock, so no value is
  // missed between those and the changes after, and none comes twice.
  CallbackId addCallbackWithHeld(const Pattern& pattern, Callback fn);
  CallbackId addValueCallbackWithHeld(const Pattern& pattern, ValueCallback fn);
  // Follows meta tuple (owner, metaKey): calls `fn` for changes of whatever
  // it points to, and, when it is re-pointed, at once with the new target's
  // current value. Never delivers a target's seqno twice or out of order.
  CallbackId addIndirectCallback(PeisId metaOwner, std::string_view metaKey, unsigned mask,
                                 Callback fn);
  // Where an indirect callback points now (as of the last event).
  std::optional<TupleRef> indirectTarget(CallbackId id) const;
  // After this returns the callback is not started again.
  bool removeCallback(CallbackId id);

  // One queued event with the callbacks it matched when it happened.
  class Delivery {
   public:
    // User-provided: a value-initialised Delivery (emplace_back()) is not
    // zero-filled first (a `rep stos` of the whole object per event).
    Delivery() noexcept {}
    // Moving the targets moves shared_ptrs and strings only: cannot throw.
    Delivery(Delivery&&) noexcept = default;
    Delivery& operator=(Delivery&&) noexcept = default;
    Delivery(const Delivery&) = default;
    Delivery& operator=(const Delivery&) = default;
    // Runs the matched callbacks in order. One that throws does not keep
    // the others from running: `onError` gets each exception; without it the
    // first one is rethrown once all have run.
    void run(const std::function<void(std::exception_ptr)>& onError = {}) const;
    EventKind kind() const { return kind_; }
    const TuplePtr& tuple() const { return tuple_; }
    // Once it ran: its tuple, for TupleSpace::recycle.
    TuplePtr takeTuple() { return std::move(tuple_); }

   private:
    friend class TupleSpace;
    // One callback to run; held by value (almost every event matches one).
    struct Target {
      explicit Target(Entry* callback) : entry(callback) {}
      Target(std::shared_ptr<Indirect> callback,
             std::shared_ptr<const std::optional<TupleRef>> to = nullptr)
          : indirect(std::move(callback)), retargetTo(std::move(to)) {}
      // Not a shared pointer: the space keeps a removed callback until the
      // deliveries that may point to it ran (deliveriesRan), so a delivery
      // touches no reference count (two atomic operations per event, the
      // dearest part of a stream's delivery).
      Entry* entry = nullptr;
      std::shared_ptr<Indirect> indirect;
      // Set: the event re-points `indirect` there (nullopt: nowhere).
      std::shared_ptr<const std::optional<TupleRef>> retargetTo;
    };
    EventKind kind_ = EventKind::Changed;
    TuplePtr tuple_;
    std::uint64_t incarnation_ = 0;  // of the tuple's owner when it happened
    boost::container::small_vector<Target, 1> targets_;
  };
  std::optional<Delivery> nextDelivery();
  // Moves every queued delivery, oldest first, to the end of `out` (empty:
  // a swap, nothing is moved; its memory becomes the queue's).
  void takeAllDeliveries(std::vector<Delivery>& out);
  bool hasPendingDeliveries() const { return queueHead_ < queue_.size(); }
  // Says that every delivery taken so far (takeAllDeliveries, nextDelivery)
  // has run or will never run: the callbacks removed before they were
  // taken are let go, moved into `letGo` for the caller to destroy once it
  // holds no lock (a callback's captures may call the kernel when
  // destroyed). Until then a delivery may point to a removed one
  // (dispatch() does not call it: a caller may still hold a delivery).
  using RemovedCallbacks = std::vector<std::shared_ptr<Entry>>;
  void deliveriesRan(RemovedCallbacks& letGo);
  // The tuples of deliveries that ran, handed back by whoever ran them:
  // the storage of those nobody else holds any more is reused for the next
  // tuples stored (a stream then allocates no tuple per update). Clears
  // `spent`.
  void recycle(std::vector<TuplePtr>& spent);
  // Runs queued deliveries until none is left; a nested call returns 0.
  std::size_t dispatch();

  // --- kernel.all-keys --------------------------------------------------------
  // The set of own keys changed since the last flush.
  bool allKeysDirty() const { return allKeysDirty_; }
  // Rewrites `kernel.all-keys` when the set of own keys changed.
  void flushAllKeys();

 private:
  // Tuples are allocated mutable and stored as const: the storage of a
  // stored tuple nobody else holds any more (a replaced value, a delivery
  // that ran) is kept in spare_ and reused by newTuple (at most
  // kMaxSpareTuples, without their data buffers beyond kSpareDataBytes).
  static constexpr std::size_t kMaxSpareTuples = 1024;
  static constexpr std::size_t kSpareDataBytes = 256;
  std::shared_ptr<Tuple> newTuple();
  std::shared_ptr<Tuple> newTuple(Tuple&& value);
  void recycle(TuplePtr&& tuple);
  std::vector<std::shared_ptr<Tuple>> spare_;
  // `isLast`: the caller found the tuple's key to be lastEntry_'s.
  // set() and write(): stamps and stores; returns the stored pointer.
  const TuplePtr& stamp(std::string_view key, std::string data, const WriteOptions& options,
                        PeisId creator);
  // Returns the stored pointer, held in tuples_.
  const TuplePtr& store(std::shared_ptr<Tuple>&& tuple, bool isLast = false);
  void remove(std::map<TupleRef, TuplePtr>::iterator it, std::uint64_t seqno);
  // `storedIn`: the map's slot that holds `tuple` (a value stored now).
  void queueEvent(EventKind kind, const TuplePtr& tuple, TuplePtr* storedIn = nullptr);
  // The delivery queued last for a value just stored may hold no reference
  // to it (queue_[unownedIndex_], whose tuple is *unownedSlot_): a stream's
  // value is then replaced, and its delivery run, without touching its
  // reference count. settle() gives that delivery its own reference
  // (before deliveries are taken, or tuples leave the map otherwise);
  // release() takes a slot's pointer before the slot is overwritten or
  // erased, handing it to that delivery if it is the one.
  void settle();
  TuplePtr release(TuplePtr& slot);
  TuplePtr* unownedSlot_ = nullptr;
  std::size_t unownedIndex_ = 0;
  // The callbacks whose mask, owner and key match an event's; the matching
  // of the last event's owner, key and kind is kept (a stream repeats one
  // key) until the callbacks change.
  const std::vector<std::shared_ptr<Entry>>& candidates(EventKind kind, const Tuple& tuple);
  struct MatchCache {
    bool valid = false;
    PeisId owner = 0;
    EventKind kind = EventKind::Changed;
    std::string key;
    std::vector<std::shared_ptr<Entry>> entries;
  };
  MatchCache matchCache_;
  CallbackId addEntry(const Pattern& pattern, unsigned mask, Callback fn, ValueCallback valueFn);
  // Queues a change event of every tuple held that matches, for callback `id` alone.
  CallbackId queueHeld(const Pattern& pattern, CallbackId id);
  void retarget(const std::shared_ptr<Indirect>& indirect);
  std::uint64_t lifeOf(PeisId owner) const { return owner == self_ ? 0 : incarnationOf(owner); }
  void checkData(std::size_t bytes) const;
  TuplePtr live(const TuplePtr& tuple) const;

  PeisId self_;
  Clock clock_;
  SpaceLimits limits_;
  std::map<TupleRef, TuplePtr> tuples_;
  // The entry stored or accepted last (a stream updates one key over and
  // over); forgotten whenever an entry is erased.
  std::map<TupleRef, TuplePtr>::iterator lastEntry_;
  bool hasLastEntry_ = false;
  bool isLastEntry(PeisId owner, std::string_view key) const;
  // Last seqno ever used per own key, so a re-created key keeps increasing.
  std::map<std::string, std::uint64_t, std::less<>> ownSeqnos_;
  std::map<std::string, std::uint64_t, std::less<>>::iterator lastSeqno_;
  bool hasLastSeqno_ = false;
  std::map<PeisId, std::uint64_t> incarnations_;  // of other owners
  PeisId lastLifeOwner_ = 0;                      // the entry of incarnations_ noted last
  std::uint64_t lastLife_ = 0;
  std::map<TupleRef, Withheld> withheld_;
  std::map<CallbackId, std::shared_ptr<Entry>> callbacks_;
  std::map<CallbackId, std::shared_ptr<Indirect>> indirects_;
  // Queued deliveries from queueHead_ on (a vector whose memory goes back
  // and forth with the kernel's batch: no allocation per delivery).
  std::vector<Delivery> queue_;
  std::size_t queueHead_ = 0;
  std::uint64_t taken_ = 0;  // deliveries ever taken from queue_
  // taken_ when deliveriesRan was called last: deliveries taken up to
  // there have run (a callback removed while none is queued or running
  // beyond it is let go at once).
  std::uint64_t ranThrough_ = 0;
  // Removed callbacks that deliveries taken before `before` was reached
  // may still point to.
  struct Retired {
    std::uint64_t before;
    std::shared_ptr<Entry> entry;
  };
  std::vector<Retired> retired_;
  CallbackId nextCallbackId_ = 1;
  bool dispatching_ = false;
  bool allKeysDirty_ = true;
  Observer observer_;
  RetargetObserver retargetObserver_;
  NameSource names_;
};

}  // namespace peis
