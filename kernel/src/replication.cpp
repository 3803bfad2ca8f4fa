// Replication decisions; see replication.h.
#include "replication.h"

#include <algorithm>

#include "peis/error.h"
#include "same_bytes.h"

namespace peis {
namespace {

Tuple withoutData(const Tuple& t) {
  Tuple head;
  head.owner = t.owner;
  head.creator = t.creator;
  head.key = t.key;
  head.mimetype = t.mimetype;
  head.encoding = t.encoding;
  head.ts_write = t.ts_write;
  head.ts_user = t.ts_user;
  head.ts_expire = t.ts_expire;
  head.seqno = t.seqno;
  return head;
}

}  // namespace

Replication::Replication(TupleSpace& space, std::uint64_t incarnation,
                         std::chrono::milliseconds lease, const Limits& limits)
    : space_(space),
      guard_(limits),
      incarnation_(incarnation),
      lease_(lease),
      outbox_(space.self(), incarnation) {}

const std::vector<Replication::Recipient>& Replication::recipientsOf(const Tuple& tuple) {
  auto& cache = recipients_;
  if (cache.valid && cache.owner == tuple.owner && sameBytes(cache.key, tuple.key)) {
    return cache.recipients;
  }
  cache.recipients.clear();
  for (const auto& [subscriber, subscriptions] : remote_) {
    for (const auto& [id, subscription] : subscriptions) {
      if (!subscription.pattern.matchesOwnerAndKey(tuple.owner, tuple.key)) continue;
      if (subscription.access && !subscription.access->allows(tuple.key)) break;
      cache.recipients.push_back(Recipient{subscriber, subscription.maxDataBytes});
      break;  // one copy per subscriber, however many of its patterns match
    }
  }
  cache.valid = true;
  cache.owner = tuple.owner;
  cache.key = tuple.key;
  return cache.recipients;
}

void Replication::onLocalEvent(EventKind kind, const TuplePtr& tuple) {
  if (tuple->owner != space_.self()) return;
  guard_.onOwnEvent(space_.self(), kind, *tuple);
  if (remote_.empty()) return;
  for (const auto& [subscriber, maxDataBytes] : recipientsOf(*tuple)) {
    if (kind == EventKind::Changed) {
      pushUpdate(subscriber, tuple, maxDataBytes);
    } else {
      push(Outgoing{subscriber, nullptr,
                    wire::TupleDeleted{incarnation_, tuple->owner, tuple->key, tuple->seqno}});
    }
  }
}

void Replication::onSubscribe(PeisId subscriber, const wire::Subscribe& subscribe, SteadyTime now) {
  if (subscribe.owner && *subscribe.owner != space_.self()) return;
  if (!reachable_.count(subscriber)) reachable_.insert(subscriber);
  Pattern pattern;
  try {
    pattern = Pattern(subscribe.keyPattern, space_.self());
  } catch (const Error&) {
    return;  // the decoder already checked it; never trust twice-removed input
  }
  remoteChanged();
  auto& subscriptions = remote_[subscriber];
  const bool isNew = !subscriptions.count(subscribe.subscription);
  const auto lease = std::chrono::milliseconds(std::max<std::uint32_t>(subscribe.leaseMs, 300));
  auto access = guard_.readAccess(subscriber);
  subscriptions.insert_or_assign(
      subscribe.subscription,
      RemoteSubscription{pattern, now + lease, subscribe.maxDataBytes, access});
  auto matching = space_.find(pattern);
  if (access) {  // only what the subscriber may read
    const auto all = matching.size();
    std::erase_if(matching, [&](const TuplePtr& t) { return !access->allows(t->key); });
    if (isNew && matching.size() < all) {
      guard_.subscriptionFiltered(space_.self(), subscriber, subscribe.keyPattern);
    }
  }
  // Does the subscriber hold exactly these values (same keys, same seqnos)?
  std::uint64_t digest = 0;
  for (const auto& tuple : matching) digest += wire::tupleDigest(tuple->key, tuple->seqno);
  const bool same = subscribe.knownCount == matching.size() && subscribe.knownDigest == digest;
  if (!isNew) {
    // A renewal: resend everything only if the subscriber's copy differs.
    if (same) return;
    ++resyncs_;
  }
  for (const auto& tuple : matching) {
    pushUpdate(subscriber, tuple, subscribe.maxDataBytes);
  }
  // It may also hold values deleted here that it never heard of.
  if (subscribe.knownCount > 0 && !same) pushManifest(subscriber, subscribe.subscription, matching);
}

void Replication::pushManifest(PeisId destination, std::uint64_t subscription,
                               const std::vector<TuplePtr>& matching) {
  std::vector<std::uint64_t> hashes;
  hashes.reserve(matching.size());
  for (const auto& tuple : matching) hashes.push_back(wire::keyHash(tuple->key));
  std::sort(hashes.begin(), hashes.end());
  hashes.erase(std::unique(hashes.begin(), hashes.end()), hashes.end());
  std::uint64_t first = 0;
  std::size_t next = 0;
  do {
    const auto end = std::min(hashes.size(), next + wire::kMaxManifestHashes);
    const bool last = end == hashes.size();
    wire::KeyManifest manifest{
        incarnation_, subscription, first, last ? UINT64_MAX : hashes[end - 1], {}};
    manifest.keyHashes.assign(hashes.begin() + next, hashes.begin() + end);
    first = manifest.rangeLast + 1;
    next = end;
    push(Outgoing{destination, nullptr, std::move(manifest)});
  } while (next < hashes.size());
}

void Replication::onUnsubscribe(PeisId subscriber, std::uint64_t subscription) {
  auto it = remote_.find(subscriber);
  if (it == remote_.end()) return;
  remoteChanged();
  it->second.erase(subscription);
  if (it->second.empty()) remote_.erase(it);
}

wire::WriteResult Replication::onWrite(PeisId source, const wire::Write& write) {
  wire::WriteResult result;
  result.request = write.request;
  const auto& t = write.tuple;
  try {
    if (t.owner != space_.self()) {
      throw Error(ErrorCode::Refused,
                  "PEIS " + std::to_string(space_.self()) + " does not own " + t.fullName());
    }
    if (auto refusal = admit(source, write)) throw *refusal;
    WriteOptions options;
    options.mimetype = t.mimetype;
    options.encoding = t.encoding;
    options.ts_user = t.ts_user;
    options.ts_expire = t.ts_expire;
    options.ttl = std::chrono::microseconds(write.ttlMicros);
    switch (write.op) {
      case wire::WriteOp::Set:
        result.seqno = space_.set(t.key, t.data, options, source)->seqno;
        break;
      case wire::WriteOp::Append:
        result.seqno = space_.append(t.key, t.data, write.ifSeqno, options, source)->seqno;
        break;
      case wire::WriteOp::Erase:
        result.seqno = space_.erase(t.key) ? space_.seqno(space_.self(), t.key) : 0;
        break;
    }
  } catch (const Error& e) {
    result.status = static_cast<std::uint8_t>(static_cast<int>(e.code()) + 1);
    result.message = e.what();
  }
  answerWrite(source, result);
  return result;
}

bool Replication::firstTimeWrite(PeisId source, std::uint64_t request) {
  // Bounded in writers too (a short-lived tool PEIS each): one forgotten.
  if (writesFrom_.size() >= kRememberedWriters && !writesFrom_.count(source))
    writesFrom_.erase(writesFrom_.begin());
  auto& recent = writesFrom_[source];
  for (const auto& [id, result] : recent) {
    if (id != request) continue;
    ++repeatedWrites_;
    if (result) push(Outgoing{source, nullptr, *result});
    return false;
  }
  recent.emplace_back(request, std::nullopt);
  if (recent.size() > kRememberedWrites) recent.pop_front();
  return true;
}

void Replication::answerWrite(PeisId source, const wire::WriteResult& result) {
  auto& recent = writesFrom_[source];
  for (auto& [id, answer] : recent) {
    if (id == result.request) answer = result;
  }
  push(Outgoing{source, nullptr, result});
}

std::optional<Error> Replication::admit(PeisId source, const wire::Write& write) {
  const auto current = space_.get(space_.self(), write.tuple.key);
  return guard_.checkWrite(space_.self(), source, write, current.get());
}

void Replication::refuseWrite(PeisId source, const wire::Write& write, const Error& error) {
  wire::WriteResult result;
  result.request = write.request;
  result.status = static_cast<std::uint8_t>(static_cast<int>(error.code()) + 1);
  result.message = error.what();
  answerWrite(source, result);
}

bool Replication::expireLeases(SteadyTime now) {
  bool dropped = false;
  for (auto it = remote_.begin(); it != remote_.end();) {
    auto& subscriptions = it->second;
    for (auto sub = subscriptions.begin(); sub != subscriptions.end();) {
      if (sub->second.expiry < now) {
        sub = subscriptions.erase(sub);
        dropped = true;
      } else {
        ++sub;
      }
    }
    it = subscriptions.empty() ? remote_.erase(it) : std::next(it);
  }
  if (dropped) remoteChanged();
  return dropped;
}

void Replication::reauthorize() {
  remoteChanged();
  for (auto& [subscriber, subscriptions] : remote_) {
    auto access = guard_.readAccess(subscriber);
    for (auto& [id, subscription] : subscriptions) subscription.access = access;
  }
}

std::vector<PeisId> Replication::subscribers() const {
  std::vector<PeisId> ids;
  for (const auto& [id, subscriptions] : remote_) ids.push_back(id);
  return ids;
}

bool Replication::covers(const LocalSubscription& local, PeisId owner) const {
  const auto& filter = local.pattern.ownerFilter();
  return owner != space_.self() && (!filter || *filter == owner);
}

wire::Subscribe Replication::subscribeMessage(const LocalSubscription& local,
                                              std::uint64_t wireId) const {
  wire::Subscribe message{wireId, static_cast<std::uint32_t>(lease_.count()),
                          local.pattern.ownerFilter(), local.pattern.keyPattern()};
  message.maxDataBytes = static_cast<std::uint32_t>(space_.limits().maxDataBytes);
  return message;
}

void Replication::sendSubscribe(LocalSubscription& local, PeisId owner) {
  auto& wireId = local.wireIds[owner];
  if (wireId != 0) push(Outgoing{owner, nullptr, wire::Unsubscribe{wireId}});
  wireId = nextWireId_++;
  // What it holds already (from before a partition, say): the owner then
  // also says which of those it deleted meanwhile.
  auto message = subscribeMessage(local, wireId);
  addKnown(message, Pattern(local.pattern.keyPattern(), owner));
  push(Outgoing{owner, nullptr, std::move(message)});
  unanswered_.push_back(
      Unanswered{owner, wireId, std::chrono::steady_clock::now() + kUnansweredAfter, 0});
}

void Replication::retryUnanswered(SteadyTime now) {
  std::vector<Unanswered> keep;
  for (auto& u : unanswered_) {
    if (u.due > now) {
      keep.push_back(u);
      continue;
    }
    // Still this subscription's id for that owner (not unsubscribed, the
    // owner not gone, no fresher id tracked on its own)?
    const LocalSubscription* local = nullptr;
    for (const auto& [handle, l] : local_) {
      const auto id = l.wireIds.find(u.owner);
      if (id != l.wireIds.end() && id->second == u.wireId) local = &l;
    }
    if (!local) continue;
    const Pattern ofOwner(local->pattern.keyPattern(), u.owner);
    if (!space_.find(ofOwner).empty() || !space_.findWithheld(ofOwner).empty()) continue;
    push(Outgoing{u.owner, nullptr, subscribeMessage(*local, u.wireId)});
    if (++u.tries < kUnansweredRetries) {
      u.due = now + kUnansweredAfter * (1 << u.tries);
      keep.push_back(u);
    }
  }
  unanswered_ = std::move(keep);
}

std::optional<Replication::SteadyTime> Replication::nextRetry() const {
  std::optional<SteadyTime> first;
  for (const auto& u : unanswered_) {
    if (!first || u.due < *first) first = u.due;
  }
  return first;
}

SubscriptionHandle Replication::subscribe(const Pattern& pattern) {
  const auto handle = nextHandle_++;
  auto& local = local_.emplace(handle, LocalSubscription{pattern, {}}).first->second;
  for (PeisId owner : reachable_) {
    if (covers(local, owner)) sendSubscribe(local, owner);
  }
  return handle;
}

bool Replication::unsubscribe(SubscriptionHandle handle) {
  auto it = local_.find(handle);
  if (it == local_.end()) return false;
  for (const auto& [owner, wireId] : it->second.wireIds) {
    push(Outgoing{owner, nullptr, wire::Unsubscribe{wireId}});
  }
  local_.erase(it);
  return true;
}

bool Replication::checkIncarnation(PeisId owner, std::uint64_t incarnation) {
  // A newer one: the owner restarted, its old tuples are gone (the space
  // forgets them and takes the new life's seqnos from 1).
  if (space_.noteIncarnation(owner, incarnation)) return true;
  ++staleDropped_;
  return false;
}

bool Replication::onUpdate(PeisId source, wire::TupleUpdate&& update) {
  if (update.tuple.owner != source) {
    ++staleDropped_;
    return false;
  }
  if (!checkIncarnation(source, update.ownerIncarnation)) return false;
  // What the stored tuple gives up for the decoded data stays in the
  // update: the network decodes its next frame into this message.
  return space_.accept(std::move(update.tuple));
}

bool Replication::onDeleted(PeisId source, const wire::TupleDeleted& deleted) {
  if (deleted.owner != source) {
    ++staleDropped_;
    return false;
  }
  if (!checkIncarnation(source, deleted.ownerIncarnation)) return false;
  return space_.acceptDelete(deleted.owner, deleted.key, deleted.seqno);
}

bool Replication::onWithheld(wire::TupleWithheld&& withheld) {
  // Any PEIS on the way may send it (it only ever says "too large here"):
  // the owner is the tuple's, its life the one the owner stamped.
  if (!checkIncarnation(withheld.tuple.owner, withheld.ownerIncarnation)) return false;
  return space_.acceptWithheld(TupleSpace::Withheld{std::move(withheld.tuple), withheld.dataBytes,
                                                    withheld.limitedBy, withheld.limit});
}

std::size_t Replication::onKeyManifest(PeisId source, const wire::KeyManifest& manifest) {
  if (!checkIncarnation(source, manifest.ownerIncarnation)) return 0;
  const LocalSubscription* local = nullptr;
  for (const auto& [handle, l] : local_) {
    const auto id = l.wireIds.find(source);
    if (id != l.wireIds.end() && id->second == manifest.subscription) local = &l;
  }
  if (!local) return 0;  // unsubscribed meanwhile, or an id of an earlier link
  const auto named = [&](const std::string& key) {
    const auto hash = wire::keyHash(key);
    return hash < manifest.rangeFirst || hash > manifest.rangeLast ||
           std::binary_search(manifest.keyHashes.begin(), manifest.keyHashes.end(), hash);
  };
  // Dropped as the owner would have: a deletion newer than the value held.
  std::vector<std::pair<std::string, std::uint64_t>> gone, goneWithheld;
  const Pattern ofOwner(local->pattern.keyPattern(), source);
  for (const auto& tuple : space_.find(ofOwner))
    if (!named(tuple->key)) gone.emplace_back(tuple->key, tuple->seqno + 1);
  for (const auto& withheld : space_.findWithheld(ofOwner))
    if (!named(withheld.tuple.key))
      goneWithheld.emplace_back(withheld.tuple.key, withheld.tuple.seqno + 1);
  std::size_t dropped = 0;
  for (const auto& [key, seqno] : gone) dropped += space_.acceptDelete(source, key, seqno) ? 1 : 0;
  for (const auto& [key, seqno] : goneWithheld) {
    space_.acceptDelete(source, key, seqno);
    dropped += space_.withheld(source, key) ? 0 : 1;
  }
  manifestDrops_ += dropped;
  return dropped;
}

void Replication::addKnown(wire::Subscribe& message, const Pattern& ofOwner) const {
  for (const auto& tuple : space_.find(ofOwner)) {
    ++message.knownCount;
    message.knownDigest += wire::tupleDigest(tuple->key, tuple->seqno);
  }
  for (const auto& withheld : space_.findWithheld(ofOwner)) {  // known, if not held
    ++message.knownCount;
    message.knownDigest += wire::tupleDigest(withheld.tuple.key, withheld.tuple.seqno);
  }
}

void Replication::renew() {
  for (auto& [handle, local] : local_) {
    for (const auto& [owner, wireId] : local.wireIds) {
      auto renewal = subscribeMessage(local, wireId);
      addKnown(renewal, Pattern(local.pattern.keyPattern(), owner));
      push(Outgoing{owner, nullptr, std::move(renewal)});
    }
  }
}

void Replication::onPeerUp(PeisId peer, std::uint64_t incarnation) {
  reachable_.insert(peer);
  // Remember the incarnation even of a peer that never sent a tuple: a
  // subscriber that restarts numbers its subscriptions from 1 again, and
  // those of its old life must not pass for renewals (no full sync).
  const auto known = space_.incarnationOf(peer);
  if (known != 0 && known != incarnation) {  // of its previous life
    remoteChanged();
    remote_.erase(peer);
    writesFrom_.erase(peer);
  }
  space_.noteIncarnation(peer, incarnation);  // a newer one forgets its old tuples
  // A fresh subscription id makes the owner send everything that matches:
  // this PEIS converges after a join, a restart or a healed partition.
  for (auto& [handle, local] : local_) {
    if (covers(local, peer)) {
      local.wireIds.erase(peer);
      sendSubscribe(local, peer);
    }
  }
}

void Replication::onRouteChanged(PeisId owner) {
  if (space_.forgetRelayWithheld(owner) == 0) return;
  for (auto& [handle, local] : local_) {
    const auto id = local.wireIds.find(owner);
    if (id == local.wireIds.end()) continue;
    auto renewal = subscribeMessage(local, id->second);
    addKnown(renewal, Pattern(local.pattern.keyPattern(), owner));
    push(Outgoing{owner, nullptr, std::move(renewal)});
  }
}

void Replication::onPeerDown(PeisId peer) {
  reachable_.erase(peer);
  remoteChanged();
  remote_.erase(peer);
  // writesFrom_ stays: a writer cut off for a moment may send its write
  // again once it is back, and must not have it applied twice.
  for (auto& [handle, local] : local_) local.wireIds.erase(peer);
}

void Replication::onRetarget(CallbackId indirect, const std::optional<TupleRef>& to) {
  if (auto it = indirectTargets_.find(indirect); it != indirectTargets_.end()) {
    unsubscribe(it->second);
    indirectTargets_.erase(it);
  }
  if (to && to->owner != space_.self()) {
    indirectTargets_[indirect] = subscribe(Pattern::exact(to->owner, to->key));
  }
}

void Replication::trackIndirectMeta(CallbackId indirect, const TupleRef& meta) {
  if (meta.owner == space_.self()) return;
  indirectMetas_[indirect] = subscribe(Pattern::exact(meta.owner, meta.key));
}

void Replication::onIndirectRemoved(CallbackId indirect) {
  for (auto* table : {&indirectTargets_, &indirectMetas_}) {
    if (auto it = table->find(indirect); it != table->end()) {
      unsubscribe(it->second);
      table->erase(it);
    }
  }
}

void Replication::pushUpdate(PeisId destination, const TuplePtr& tuple,
                             std::uint32_t maxDataBytes) {
  if (tuple->data.size() > maxDataBytes) {
    // The subscriber would have to drop the update: say what it misses.
    return push(Outgoing{
        destination, nullptr,
        wire::TupleWithheld{incarnation_, destination, maxDataBytes,
                            static_cast<std::uint32_t>(tuple->data.size()), withoutData(*tuple)}});
  }
  outbox_.pushUpdate(destination, tuple);
}

std::vector<Replication::Outgoing> Replication::takeOutbox(std::size_t most) {
  std::vector<Outgoing> out;
  outbox_.take(out, most);
  return out;
}

}  // namespace peis
