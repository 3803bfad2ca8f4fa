// Replication: what makes one PEIS's tuple space part of the distributed
// one, as decisions on values (no sockets): the owner side (remote
// subscribers with leases, full sync on a new subscription, applying remote
// writes) and the subscriber side (subscriptions per owner, re-subscribing
// when an owner appears or restarts, accepting updates in seqno order per
// owner incarnation; the space keeps the incarnations). An owner sends a
// value over a subscriber's data limit as TupleWithheld, not as an update
// the subscriber would have to drop. Its output is the outbox (outbox.h) that the Kernel
// hands to the Network on the kernel thread. Every method is called with
// the Kernel's lock held.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <vector>

#include "net/wire.h"
#include "outbox.h"
#include "owner_guard.h"
#include "peis/kernel.h"
#include "tuple_space.h"

namespace peis {

class Replication {
 public:
  using SteadyTime = std::chrono::steady_clock::time_point;

  using Outgoing = Outbox::Outgoing;

  Replication(TupleSpace& space, std::uint64_t incarnation, std::chrono::milliseconds lease,
              const Limits& limits = {});

  // --- owner side ---------------------------------------------------------
  // Observer of the local space: pushes own changes to matching subscribers.
  void onLocalEvent(EventKind kind, const TuplePtr& tuple);
  void onSubscribe(PeisId subscriber, const wire::Subscribe& subscribe, SteadyTime now);
  void onUnsubscribe(PeisId subscriber, std::uint64_t subscription);
  // What the owner refuses of other PEIS (its checks run in onWrite).
  OwnerGuard& guard() { return guard_; }
  // The guard's verdict on a remote write of an own tuple (nullopt: it may
  // be applied); onWrite asks it too.
  std::optional<Error> admit(PeisId source, const wire::Write& write);
  // Applies a remote write, unless the guard refuses it; returns the result
  // to send back.
  wire::WriteResult onWrite(PeisId source, const wire::Write& write);
  // Answers a remote write with an error instead of applying it.
  void refuseWrite(PeisId source, const wire::Write& write, const Error& error);
  // Whether a remote write is seen for the first time (it is then noted as
  // being decided). A writer sends a write again when it misses the answer:
  // a repeat is answered again with the result sent before, or ignored
  // while the first copy is being decided (write gate). The last
  // kRememberedWrites request ids of each writer are remembered.
  bool firstTimeWrite(PeisId source, std::uint64_t request);
  static constexpr std::size_t kRememberedWrites = 256;
  static constexpr std::size_t kRememberedWriters = 1024;
  // Repeated writes answered again or ignored.
  std::uint64_t repeatedWrites() const { return repeatedWrites_; }
  // Drops subscriptions whose lease ran out; true if any was dropped.
  bool expireLeases(SteadyTime now);
  std::vector<PeisId> subscribers() const;
  // The policy changed: what each subscriber may read is asked again.
  void reauthorize();

  // --- subscriber side ----------------------------------------------------------
  SubscriptionHandle subscribe(const Pattern& pattern);
  bool unsubscribe(SubscriptionHandle handle);
  // Accepts an owner's update / delete; false if stale or spoofed (counted).
  bool onUpdate(PeisId source, wire::TupleUpdate&& update);
  bool onDeleted(PeisId source, const wire::TupleDeleted& deleted);
  // A value over a data limit (from its owner or a relay on the way); false
  // if stale.
  bool onWithheld(wire::TupleWithheld&& withheld);
  // An owner's list of the keys it holds, after a full sync: what this PEIS
  // holds of that owner in the list's range and the subscription's pattern
  // but the list does not name was deleted there; it is dropped here.
  // Returns how many tuples were dropped.
  std::size_t onKeyManifest(PeisId source, const wire::KeyManifest& manifest);
  // Re-sends every subscription (lease renewal).
  void renew();
  void onPeerUp(PeisId peer, std::uint64_t incarnation);
  // The route to `owner` goes another way now: what a PEIS on the old way
  // withheld is forgotten and the owner asked again (a renewal that no
  // longer counts it), so it comes if the new way lets it pass.
  void onRouteChanged(PeisId owner);
  void onPeerDown(PeisId peer);
  // A fresh Subscribe that brought no value yet is sent again (same id, like
  // a renewal) kUnansweredRetries times, kUnansweredAfter and then twice
  // that later: one lost on a route that changed under it (the join of many
  // PEIS) is then recovered long before the next lease renewal. An owner
  // that holds no matching tuple costs these few Subscribes and no more.
  void retryUnanswered(SteadyTime now);
  // When retryUnanswered has work, if it has any.
  std::optional<SteadyTime> nextRetry() const;
  bool hasUnanswered() const { return !unanswered_.empty(); }
  static constexpr std::chrono::milliseconds kUnansweredAfter{500};
  static constexpr int kUnansweredRetries = 2;
  // Keeps a subscription to whatever an indirect callback points at.
  void onRetarget(CallbackId indirect, const std::optional<TupleRef>& to);
  void onIndirectRemoved(CallbackId indirect);
  // Also subscribe to the meta tuple of an indirect callback when remote.
  void trackIndirectMeta(CallbackId indirect, const TupleRef& meta);

  // The outbox (outbox.h): what this PEIS sends, per destination.
  Outbox& outbox() { return outbox_; }
  // Shorthands of the outbox (the tests read it through them).
  std::vector<Outgoing> takeOutbox(std::size_t most = SIZE_MAX);
  void takeOutbox(std::vector<Outgoing>& out, std::size_t most, std::size_t mostBytes = SIZE_MAX) {
    outbox_.take(out, most, mostBytes);
  }
  bool hasOutgoing() const { return !outbox_.empty(); }
  std::size_t outboxBytes() const { return outbox_.bytes(); }
  std::uint64_t coalesced() const { return outbox_.coalesced(); }
  void recycleFrames(std::string&& frames) { outbox_.recycleFrames(std::move(frames)); }
  static constexpr std::size_t kTrackOutboxAbove = Outbox::kTrackAbove;
  static constexpr std::size_t kCoalesceOutboxAbove = Outbox::kCoalesceAbove;
  static constexpr std::size_t kFramesPerEntryBytes = Outbox::kFramesPerEntryBytes;
  // This PEIS took a new id: frames encoded with the old one are dropped
  // (subscribers re-sync with the new id).
  void onSelfChanged() { outbox_.changeSelf(space_.self()); }
  std::uint64_t staleDropped() const { return staleDropped_; }
  // Renewals that showed a subscriber missing values, answered by a resync.
  std::uint64_t resyncs() const { return resyncs_; }
  // Tuples dropped because the owner's KeyManifest no longer named them.
  std::uint64_t manifestDrops() const { return manifestDrops_; }
  std::uint64_t incarnation() const { return incarnation_; }

 private:
  struct RemoteSubscription {
    Pattern pattern;
    SteadyTime expiry;
    std::uint32_t maxDataBytes = wire::kNoDataLimit;  // the subscriber's limit
    // What the subscriber may read (a secured ecology's policy); null: all.
    std::shared_ptr<const OwnerGuard::ReadAccess> access;
  };
  struct LocalSubscription {
    Pattern pattern;
    std::map<PeisId, std::uint64_t> wireIds;  // per owner it was sent to
  };
  void sendSubscribe(LocalSubscription& local, PeisId owner);
  struct Unanswered {
    PeisId owner;
    std::uint64_t wireId;
    SteadyTime due;
    int tries;
  };
  std::vector<Unanswered> unanswered_;
  bool covers(const LocalSubscription& local, PeisId owner) const;
  bool checkIncarnation(PeisId owner, std::uint64_t incarnation);
  wire::Subscribe subscribeMessage(const LocalSubscription& local, std::uint64_t wireId) const;

  TupleSpace& space_;
  OwnerGuard guard_;
  std::uint64_t incarnation_;
  std::chrono::milliseconds lease_;
  std::map<PeisId, std::map<std::uint64_t, RemoteSubscription>> remote_;
  // The subscribers an event of an own tuple goes to (one copy each) and
  // their data limits. The answer for the last event's key is kept (a
  // stream repeats one key) until remote_ changes: every change of it
  // calls remoteChanged().
  struct Recipient {
    PeisId subscriber;
    std::uint32_t maxDataBytes;
  };
  struct RecipientCache {
    bool valid = false;
    PeisId owner = 0;
    std::string key;
    std::vector<Recipient> recipients;
  };
  RecipientCache recipients_;
  const std::vector<Recipient>& recipientsOf(const Tuple& tuple);
  void remoteChanged() { recipients_.valid = false; }
  // Per writer, its latest request ids and their results (none: deciding).
  std::map<PeisId, std::deque<std::pair<std::uint64_t, std::optional<wire::WriteResult>>>>
      writesFrom_;
  std::uint64_t repeatedWrites_ = 0;
  void answerWrite(PeisId source, const wire::WriteResult& result);
  std::map<SubscriptionHandle, LocalSubscription> local_;
  std::map<CallbackId, SubscriptionHandle> indirectTargets_;
  std::map<CallbackId, SubscriptionHandle> indirectMetas_;
  std::set<PeisId> reachable_;
  void push(Outgoing outgoing) { outbox_.push(std::move(outgoing)); }
  void pushUpdate(PeisId destination, const TuplePtr& tuple, std::uint32_t maxDataBytes);
  // The keys of `matching`, as KeyManifests in hash ranges, for a subscriber.
  void pushManifest(PeisId destination, std::uint64_t subscription,
                    const std::vector<TuplePtr>& matching);
  // What this PEIS holds or knows as withheld of an owner's tuples matching
  // `ofOwner`: Subscribe's known count and known digest.
  void addKnown(wire::Subscribe& message, const Pattern& ofOwner) const;
  Outbox outbox_;
  SubscriptionHandle nextHandle_ = 1;
  std::uint64_t nextWireId_ = 1;
  std::uint64_t staleDropped_ = 0;
  std::uint64_t resyncs_ = 0;
  std::uint64_t manifestDrops_ = 0;
};

}  // namespace peis
