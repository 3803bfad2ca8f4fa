// TupleSpace implementation; see tuple_space.h for the contract.
#include "tuple_space.h"

#include <algorithm>
#include <atomic>
#include <iterator>
#include <type_traits>
#include <utility>

#include "peis/error.h"
#include "peis/key.h"
#include "same_bytes.h"
#include "saturating_time.h"

// ThreadSanitizer does not model the fence that orders the reuse of a
// stored tuple after its last holder let go (TupleSpace::recycle): under it,
// tuples are not reused.
#if defined(__SANITIZE_THREAD__)
#define PEIS_NO_TUPLE_REUSE 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define PEIS_NO_TUPLE_REUSE 1
#endif
#endif

namespace peis {

struct TupleSpace::Entry {
  Pattern pattern;
  unsigned mask = kOnAny;
  Callback fn;
  // Or, for a callback that takes the tuple alone (Kernel::onChange), that
  // function itself: one call per event rather than two.
  ValueCallback valueFn;
  std::atomic<bool> active{true};  // cleared by removeCallback from any thread
};

// An indirect callback. `queueTarget` is where events are matched (under the
// owner's serialisation); `deliverTarget` and the last delivered (incarnation,
// seqno) are only touched when deliveries run, in queue order.
struct TupleSpace::Indirect {
  TupleRef meta;
  unsigned mask = kOnAny;
  Callback fn;
  std::atomic<bool> active{true};  // cleared by removeCallback from any thread
  bool targeted = false;
  std::optional<TupleRef> queueTarget;
  std::optional<TupleRef> deliverTarget;
  std::uint64_t lastIncarnation = 0;
  std::uint64_t lastSeqno = 0;
};

namespace {

TupleRef refOf(const Tuple& tuple) { return TupleRef{tuple.owner, tuple.key}; }

bool sameRef(const std::optional<TupleRef>& ref, const Tuple& tuple) {
  return ref && ref->owner == tuple.owner && ref->key == tuple.key;
}

void checkMimetype(const std::string& mimetype) {
  if (mimetype.size() > kMaxMimetypeBytes) {
    throw Error(ErrorCode::InvalidArgument, "mimetype is " + std::to_string(mimetype.size()) +
                                                " bytes long; at most " +
                                                std::to_string(kMaxMimetypeBytes) + " are allowed");
  }
}

}  // namespace

void TupleSpace::Delivery::run(const std::function<void(std::exception_ptr)>& onError) const {
  std::exception_ptr first;
  auto call = [&](const auto& fn, EventKind kind) {
    try {
      if constexpr (std::is_same_v<std::decay_t<decltype(fn)>, ValueCallback>) {
        fn(*tuple_);
      } else {
        fn(kind, *tuple_);
      }
    } catch (...) {
      if (onError) {
        onError(std::current_exception());
      } else if (!first) {
        first = std::current_exception();
      }
    }
  };
  for (const auto& target : targets_) {
    if (target.entry) {
      const auto& entry = *target.entry;
      if (entry.active && tuple_ && (entry.mask & static_cast<unsigned>(kind_))) {
        if (entry.valueFn) {
          call(entry.valueFn, kind_);
        } else {
          call(entry.fn, kind_);
        }
      }
      continue;
    }
    auto& indirect = *target.indirect;
    if (!indirect.active) continue;
    if (target.retargetTo) {
      indirect.deliverTarget = *target.retargetTo;
      indirect.lastIncarnation = incarnation_;
      indirect.lastSeqno = 0;
      if (tuple_) {
        indirect.lastSeqno = tuple_->seqno;
        if (indirect.mask & kOnChange) call(indirect.fn, EventKind::Changed);
      }
      continue;
    }
    if (!tuple_ || !sameRef(indirect.deliverTarget, *tuple_)) continue;
    // A new life of the target's owner numbers from 1 again: it is newer.
    const bool newer =
        incarnation_ > indirect.lastIncarnation ||
        (incarnation_ == indirect.lastIncarnation && tuple_->seqno > indirect.lastSeqno);
    if (!newer) continue;
    indirect.lastIncarnation = incarnation_;
    indirect.lastSeqno = tuple_->seqno;
    if (indirect.mask & static_cast<unsigned>(kind_)) call(indirect.fn, kind_);
  }
  if (first) std::rethrow_exception(first);
}

TupleSpace::TupleSpace(PeisId self, Clock clock, SpaceLimits limits)
    : self_(self), clock_(std::move(clock)), limits_(limits) {
  if (!isValidPeisId(self)) {
    throw Error(ErrorCode::InvalidArgument, "invalid PEIS id " + std::to_string(self));
  }
  if (limits_.maxDataBytes > kMaxDataBytes) limits_.maxDataBytes = kMaxDataBytes;
}

TupleSpace::~TupleSpace() = default;

void TupleSpace::changeSelf(PeisId newId) {
  if (!isValidPeisId(newId)) {
    throw Error(ErrorCode::InvalidArgument, "invalid PEIS id " + std::to_string(newId));
  }
  settle();  // tuples leave the map below
  hasLastEntry_ = false;
  std::vector<Tuple> own;
  for (auto it = tuples_.lower_bound(TupleRef{self_, ""});
       it != tuples_.end() && it->first.owner == self_;) {
    Tuple moved = *it->second;
    moved.owner = newId;
    if (moved.creator == self_) moved.creator = newId;
    own.push_back(std::move(moved));
    it = tuples_.erase(it);
  }
  tuples_.erase(TupleRef{newId, ""});  // nothing cached may claim the new id
  for (auto it = tuples_.lower_bound(TupleRef{newId, ""});
       it != tuples_.end() && it->first.owner == newId;) {
    it = tuples_.erase(it);
  }
  for (auto it = withheld_.lower_bound(TupleRef{newId, ""});
       it != withheld_.end() && it->first.owner == newId;) {
    it = withheld_.erase(it);
  }
  incarnations_.erase(newId);
  lastLifeOwner_ = 0;
  const PeisId oldId = self_;
  self_ = newId;
  // Callbacks on this PEIS's own tuples follow it to its new id.
  for (auto& [id, entry] : callbacks_) {
    if (entry->pattern.ownerFilter() == oldId) entry->pattern.owner(newId);
  }
  matchCache_.valid = false;
  for (auto& [id, indirect] : indirects_) {
    if (indirect->meta.owner == oldId) indirect->meta.owner = newId;
  }
  for (auto& tuple : own) store(newTuple(std::move(tuple)));
  refreshIndirects();
  allKeysDirty_ = true;
}

void TupleSpace::checkData(std::size_t bytes) const {
  if (bytes > limits_.maxDataBytes) {
    throw Error(ErrorCode::TooLarge,
                "data is " + std::to_string(bytes) + " bytes; this PEIS accepts at most " +
                    std::to_string(limits_.maxDataBytes) + " (see --peis-max-data)");
  }
}

TuplePtr TupleSpace::live(const TuplePtr& tuple) const {
  if (!tuple || tuple->isExpiredAt(clock_())) return nullptr;
  return tuple;
}

bool TupleSpace::isLastEntry(PeisId owner, std::string_view key) const {
  return hasLastEntry_ && lastEntry_->first.owner == owner && sameBytes(lastEntry_->first.key, key);
}

std::shared_ptr<Tuple> TupleSpace::newTuple() {
  if (spare_.empty()) return std::make_shared<Tuple>();
  auto tuple = std::move(spare_.back());
  spare_.pop_back();
  return tuple;
}

std::shared_ptr<Tuple> TupleSpace::newTuple(Tuple&& value) {
  auto tuple = newTuple();
  // Every field. The spare storage of a stream's last value holds its key
  // and mimetype already: equal ones are not copied again. The data buffers
  // are swapped: `value` gets the spare's, for the next decoded update (a
  // received message is decoded into again), with its size, which a
  // stream's next update mostly has too.
  Tuple& t = *tuple;
  t.owner = value.owner;
  t.creator = value.creator;
  if (!sameBytes(t.key, value.key)) t.key = std::move(value.key);
  t.data.swap(value.data);
  if (!sameBytes(t.mimetype, value.mimetype)) t.mimetype = std::move(value.mimetype);
  t.encoding = value.encoding;
  t.ts_write = value.ts_write;
  t.ts_user = value.ts_user;
  t.ts_expire = value.ts_expire;
  t.seqno = value.seqno;
  return tuple;
}

void TupleSpace::recycle(TuplePtr&& tuple) {
  // Nobody else holds it when the count is 1 (and nobody can take a copy
  // from us). The acquire fence orders our reuse after the other holders'
  // last reads, which happened before their releases of it.
#ifndef PEIS_NO_TUPLE_REUSE
  if (tuple && tuple.use_count() == 1 && spare_.size() < kMaxSpareTuples) {
    std::atomic_thread_fence(std::memory_order_acquire);
    // Allocated mutable by newTuple (only the space allocates stored tuples).
    auto spare = std::const_pointer_cast<Tuple>(std::move(tuple));
    if (spare->data.capacity() > kSpareDataBytes) spare->data = std::string();
    spare_.push_back(std::move(spare));
    return;
  }
#endif
  tuple.reset();
}

void TupleSpace::recycle(std::vector<TuplePtr>& spent) {
  for (auto& tuple : spent) recycle(std::move(tuple));
  spent.clear();
}

const TuplePtr& TupleSpace::store(std::shared_ptr<Tuple>&& tuple, bool isLast) {
  // Moved, not copied, into the map: a stream's update takes no reference
  // of its own (two atomic operations per update on the writer).
  if (!(isLast || isLastEntry(tuple->owner, tuple->key))) {
    auto [it, inserted] = tuples_.try_emplace(refOf(*tuple));
    if (inserted && tuple->owner == self_) allKeysDirty_ = true;
    lastEntry_ = it;
    hasLastEntry_ = true;
  }
  auto& slot = lastEntry_->second;
  auto replaced = release(slot);
  slot = std::move(tuple);
  recycle(std::move(replaced));
  // queueEvent leaves tuples_ as it is: the reference stays valid.
  queueEvent(EventKind::Changed, slot, &slot);
  return slot;
}

void TupleSpace::settle() {
  if (!unownedSlot_) return;
  queue_[unownedIndex_].tuple_ = *unownedSlot_;
  unownedSlot_ = nullptr;
}

TuplePtr TupleSpace::release(TuplePtr& slot) {
  if (unownedSlot_ != &slot) return std::move(slot);
  // The delivery of the value leaving takes the map's reference.
  queue_[unownedIndex_].tuple_ = std::move(slot);
  unownedSlot_ = nullptr;
  return nullptr;
}

TuplePtr TupleSpace::set(std::string_view key, std::string data, const WriteOptions& options,
                         PeisId creator) {
  return stamp(key, std::move(data), options, creator);
}

const Tuple& TupleSpace::write(std::string_view key, std::string data, const WriteOptions& options,
                               PeisId creator) {
  return *stamp(key, std::move(data), options, creator);
}

const TuplePtr& TupleSpace::stamp(std::string_view key, std::string data,
                                  const WriteOptions& options, PeisId creator) {
  const bool isLast = isLastEntry(self_, key);
  if (!isLast) validateKey(key);  // a key already held was checked before
  checkData(data.size());
  checkMimetype(options.mimetype);
  const auto now = clock_();
  // Entries of ownSeqnos_ are never erased: the one used last stays valid.
  if (!hasLastSeqno_ || !sameBytes(lastSeqno_->first, key)) {
    lastSeqno_ = ownSeqnos_.find(key);
    if (lastSeqno_ == ownSeqnos_.end()) lastSeqno_ = ownSeqnos_.emplace(std::string(key), 0).first;
    hasLastSeqno_ = true;
  }
  auto& seqno = lastSeqno_->second;
  // Every field is written: the storage may be a spare one.
  auto ptr = newTuple();
  Tuple& tuple = *ptr;
  tuple.owner = self_;
  tuple.creator = creator == 0 ? self_ : creator;
  // A spare storage of the key's last value holds its key and mimetype.
  if (!sameBytes(tuple.key, key)) tuple.key.assign(key);
  tuple.data = std::move(data);
  if (!sameBytes(tuple.mimetype, options.mimetype)) tuple.mimetype = options.mimetype;
  tuple.encoding = options.encoding;
  tuple.ts_write = now;
  tuple.ts_user = options.ts_user;
  tuple.ts_expire = options.ts_expire != kNoTime ? options.ts_expire
                    : options.ttl.count() > 0    ? saturatingAdd(now, options.ttl)
                                                 : kNoTime;
  tuple.seqno = ++seqno;
  return store(std::move(ptr), isLast);
}

TuplePtr TupleSpace::setKernelTuple(std::string_view key, std::string data) {
  const auto limit = limits_.maxDataBytes;
  limits_.maxDataBytes = kMaxDataBytes;
  struct Restore {
    SpaceLimits& limits;
    std::size_t value;
    ~Restore() { limits.maxDataBytes = value; }
  } restore{limits_, limit};
  return set(key, std::move(data));
}

TuplePtr TupleSpace::append(std::string_view key, std::string_view data,
                            std::optional<std::uint64_t> ifSeqno, const WriteOptions& options,
                            PeisId creator) {
  validateKey(key);
  const auto current = get(self_, key);
  const std::uint64_t currentSeqno = current ? current->seqno : 0;
  if (ifSeqno && *ifSeqno != currentSeqno) {
    throw Error(ErrorCode::Conflict, "append to " + fullName(self_, key) + " expected seqno " +
                                         std::to_string(*ifSeqno) + " but it is " +
                                         std::to_string(currentSeqno));
  }
  const std::size_t oldSize = current ? current->data.size() : 0;
  if (data.size() > limits_.maxDataBytes || oldSize > limits_.maxDataBytes - data.size()) {
    checkData(oldSize + data.size() > oldSize ? oldSize + data.size() : limits_.maxDataBytes + 1);
  }
  std::string joined;
  joined.reserve(oldSize + data.size());
  if (current) joined = current->data;
  joined.append(data);
  WriteOptions merged = options;
  if (current) {
    merged.mimetype = current->mimetype;
    merged.encoding = current->encoding;
  }
  return set(key, std::move(joined), merged, creator);
}

TuplePtr TupleSpace::setDefault(std::string_view key, std::string data,
                                const WriteOptions& options) {
  if (auto current = get(self_, key)) return current;
  return set(key, std::move(data), options);
}

bool TupleSpace::erase(std::string_view key) {
  validateKey(key);
  auto it = tuples_.find(TupleRef{self_, std::string(key)});
  if (it == tuples_.end()) return false;
  const auto seqno = ++ownSeqnos_[std::string(key)];
  remove(it, seqno);
  return true;
}

void TupleSpace::remove(std::map<TupleRef, TuplePtr>::iterator it, std::uint64_t seqno) {
  hasLastEntry_ = false;
  Tuple last = *it->second;
  last.seqno = seqno;
  if (last.owner == self_) {
    last.ts_write = clock_();
    allKeysDirty_ = true;
  }
  release(it->second);  // a delivery of it still queued keeps it
  tuples_.erase(it);
  queueEvent(EventKind::Deleted, newTuple(std::move(last)));
}

std::uint64_t TupleSpace::incarnationOf(PeisId owner) const {
  auto it = incarnations_.find(owner);
  return it == incarnations_.end() ? 0 : it->second;
}

bool TupleSpace::noteIncarnation(PeisId owner, std::uint64_t incarnation) {
  if (incarnation == 0 || owner == self_) return true;
  if (owner == lastLifeOwner_ && incarnation == lastLife_) return true;  // a stream
  auto [it, first] = incarnations_.try_emplace(owner, incarnation);
  if (!first && incarnation < it->second) return false;
  if (!first && incarnation > it->second) {
    // Its delete events belong to the old life: recorded before the new one.
    forgetOwner(owner);
    it->second = incarnation;
  }
  lastLifeOwner_ = owner;
  lastLife_ = incarnation;
  return true;
}

bool TupleSpace::accept(Tuple&& tuple, std::uint64_t incarnation) {
  if (tuple.owner == self_ || !isValidPeisId(tuple.owner)) return false;
  checkData(tuple.data.size());
  if (!noteIncarnation(tuple.owner, incarnation)) return false;
  if (!withheld_.empty()) {
    auto w = withheld_.find(refOf(tuple));
    if (w != withheld_.end()) {
      if (w->second.tuple.seqno >= tuple.seqno) return false;
      withheld_.erase(w);
    }
  }
  auto it = isLastEntry(tuple.owner, tuple.key) ? lastEntry_ : tuples_.find(refOf(tuple));
  if (it == tuples_.end()) {
    if (keyProblem(tuple.key)) return false;  // a key already held was checked before
    store(newTuple(std::move(tuple)));
    return true;
  }
  lastEntry_ = it;
  hasLastEntry_ = true;
  if (it->second->seqno >= tuple.seqno) return false;
  // One lookup: replaced in place.
  auto replaced = release(it->second);
  it->second = newTuple(std::move(tuple));
  recycle(std::move(replaced));
  queueEvent(EventKind::Changed, it->second, &it->second);
  return true;
}

bool TupleSpace::acceptDelete(PeisId owner, std::string_view key, std::uint64_t seqno,
                              std::uint64_t incarnation) {
  if (owner == self_ || !noteIncarnation(owner, incarnation)) return false;
  if (auto w = withheld_.find(TupleRef{owner, std::string(key)});
      w != withheld_.end() && w->second.tuple.seqno < seqno) {
    withheld_.erase(w);
  }
  auto it = tuples_.find(TupleRef{owner, std::string(key)});
  if (it == tuples_.end() || it->second->seqno >= seqno) return false;
  remove(it, seqno);
  return true;
}

bool TupleSpace::acceptWithheld(Withheld&& withheld, std::uint64_t incarnation) {
  auto& t = withheld.tuple;
  if (t.owner == self_ || !isValidPeisId(t.owner) || keyProblem(t.key)) return false;
  if (!noteIncarnation(t.owner, incarnation)) return false;
  auto ref = refOf(t);
  if (auto w = withheld_.find(ref); w != withheld_.end() && w->second.tuple.seqno >= t.seqno) {
    return false;
  }
  if (auto it = tuples_.find(ref); it != tuples_.end()) {
    if (it->second->seqno >= t.seqno) return false;
    remove(it, t.seqno);  // the owner's value is no longer the one held here
  }
  t.data.clear();
  withheld_.insert_or_assign(std::move(ref), std::move(withheld));
  return true;
}

std::optional<TupleSpace::Withheld> TupleSpace::withheld(PeisId owner, std::string_view key) const {
  auto it = withheld_.find(TupleRef{owner, std::string(key)});
  if (it == withheld_.end() || it->second.tuple.isExpiredAt(clock_())) return std::nullopt;
  return it->second;
}

std::vector<TupleSpace::Withheld> TupleSpace::findWithheld(const Pattern& pattern) const {
  std::vector<Withheld> found;
  if (withheld_.empty()) return found;
  const auto now = clock_();
  for (const auto& [ref, w] : withheld_) {
    if (pattern.matches(w.tuple) && !w.tuple.isExpiredAt(now)) found.push_back(w);
  }
  return found;
}

std::size_t TupleSpace::forgetRelayWithheld(PeisId owner) {
  return std::erase_if(withheld_, [&](const auto& entry) {
    const auto& w = entry.second;
    return entry.first.owner == owner && w.limitedBy != owner && w.limitedBy != self_;
  });
}

std::string TupleSpace::Withheld::reason(PeisId self) const {
  const auto head =
      tuple.fullName() + " is " + std::to_string(dataBytes) + " bytes: too large for ";
  if (limitedBy == self) {
    return head + "this PEIS's --peis-max-data (" + std::to_string(limit) + " bytes; PEIS " +
           std::to_string(self) + ")";
  }
  return head + "the --peis-max-data of PEIS " + std::to_string(limitedBy) +
         " on the way from its owner (" + std::to_string(limit) + " bytes)";
}

std::size_t TupleSpace::forgetOwner(PeisId owner) {
  if (owner == self_) return 0;
  for (auto it = withheld_.lower_bound(TupleRef{owner, ""});
       it != withheld_.end() && it->first.owner == owner;) {
    it = withheld_.erase(it);
  }
  std::size_t count = 0;
  for (auto it = tuples_.lower_bound(TupleRef{owner, ""});
       it != tuples_.end() && it->first.owner == owner;) {
    auto next = std::next(it);
    remove(it, it->second->seqno);
    it = next;
    ++count;
  }
  return count;
}

TuplePtr TupleSpace::get(PeisId owner, std::string_view key) const {
  auto it = tuples_.find(TupleRef{owner, std::string(key)});
  return it == tuples_.end() ? nullptr : live(it->second);
}

std::vector<TuplePtr> TupleSpace::find(const Pattern& pattern) const {
  std::vector<TuplePtr> found;
  auto consider = [&](const TuplePtr& tuple) {
    if (pattern.matches(*tuple) && live(tuple)) found.push_back(tuple);
  };
  const auto& owner = pattern.ownerFilter();
  if (owner) {
    for (auto it = tuples_.lower_bound(TupleRef{*owner, ""});
         it != tuples_.end() && it->first.owner == *owner; ++it) {
      consider(it->second);
    }
  } else {
    for (const auto& [ref, tuple] : tuples_) consider(tuple);
  }
  return found;
}

std::uint64_t TupleSpace::seqno(PeisId owner, std::string_view key) const {
  if (owner == self_) {
    auto it = ownSeqnos_.find(key);
    return it == ownSeqnos_.end() ? 0 : it->second;
  }
  auto tuple = get(owner, key);
  return tuple ? tuple->seqno : 0;
}

std::vector<std::string> TupleSpace::keysOf(PeisId owner) const {
  std::vector<std::string> keys;
  for (auto it = tuples_.lower_bound(TupleRef{owner, ""});
       it != tuples_.end() && it->first.owner == owner; ++it) {
    keys.push_back(it->first.key);
  }
  return keys;
}

std::vector<PeisId> TupleSpace::peisNamed(std::string_view name) const {
  std::vector<PeisId> ids = names_ ? names_(name) : std::vector<PeisId>{};
  for (const auto& [ref, tuple] : tuples_) {
    if (ref.key == "kernel.name" && tuple->data == name && live(tuple)) ids.push_back(ref.owner);
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

void TupleSpace::refreshIndirects() {
  std::vector<std::shared_ptr<Indirect>> all;
  for (const auto& [id, indirect] : indirects_) all.push_back(indirect);
  for (const auto& indirect : all) retarget(indirect);
}

PeisId TupleSpace::resolveOwner(std::string_view owner) const {
  if (auto id = parsePeisId(owner)) return *id;
  validateName(owner);
  const auto ids = peisNamed(owner);
  if (ids.empty()) {
    throw Error(ErrorCode::NotFound, "no known PEIS is named '" + std::string(owner) + "'");
  }
  if (ids.size() > 1) {
    std::string list;
    for (auto id : ids) list += (list.empty() ? "" : ", ") + std::to_string(id);
    throw Error(ErrorCode::AmbiguousName, "the name '" + std::string(owner) +
                                              "' is ambiguous: it is carried by PEIS " + list +
                                              "; use an id instead");
  }
  return ids.front();
}

std::size_t TupleSpace::expire() {
  const auto now = clock_();
  std::vector<TupleRef> expired;
  for (const auto& [ref, tuple] : tuples_) {
    if (tuple->isExpiredAt(now)) expired.push_back(ref);
  }
  for (const auto& ref : expired) {
    auto it = tuples_.find(ref);
    const auto seqno = ref.owner == self_ ? ++ownSeqnos_[ref.key] : it->second->seqno;
    remove(it, seqno);
  }
  std::erase_if(withheld_, [&](const auto& entry) { return entry.second.tuple.isExpiredAt(now); });
  return expired.size();
}

Timestamp TupleSpace::nextExpiry() const {
  Timestamp next = kNoTime;
  for (const auto& [ref, tuple] : tuples_) {
    if (tuple->ts_expire != kNoTime && (next == kNoTime || tuple->ts_expire < next)) {
      next = tuple->ts_expire;
    }
  }
  return next;
}

void TupleSpace::declareMeta(std::string_view metaKey) {
  WriteOptions options;
  options.mimetype = kMetaMimetype;
  setDefault(metaKey, "", options);
}

TuplePtr TupleSpace::setMeta(std::string_view metaKey, const TupleRef& target) {
  if (!isValidPeisId(target.owner)) {
    throw Error(ErrorCode::InvalidArgument,
                "meta tuple target owner " + std::to_string(target.owner) + " is not a PEIS id");
  }
  validateKey(target.key);
  WriteOptions options;
  options.mimetype = kMetaMimetype;
  return set(metaKey, target.str(), options);
}

std::optional<TupleRef> TupleSpace::resolveMeta(PeisId owner, std::string_view metaKey) const {
  const auto meta = get(owner, metaKey);
  if (!meta || meta->data.empty()) return std::nullopt;
  try {
    const auto name = parseFullName(meta->data);
    return TupleRef{resolveOwner(name.owner), name.key};
  } catch (const Error&) {
    return std::nullopt;  // points at something malformed or unknown: unresolved
  }
}

TuplePtr TupleSpace::getIndirect(PeisId owner, std::string_view metaKey) const {
  const auto target = resolveMeta(owner, metaKey);
  return target ? get(target->owner, target->key) : nullptr;
}

CallbackId TupleSpace::addCallback(const Pattern& pattern, unsigned mask, Callback fn) {
  return addEntry(pattern, mask, std::move(fn), nullptr);
}

CallbackId TupleSpace::addValueCallback(const Pattern& pattern, unsigned mask, ValueCallback fn) {
  return addEntry(pattern, mask, nullptr, std::move(fn));
}

CallbackId TupleSpace::addEntry(const Pattern& pattern, unsigned mask, Callback fn,
                                ValueCallback valueFn) {
  const auto id = nextCallbackId_++;
  auto entry = std::make_shared<Entry>();
  entry->pattern = pattern;
  entry->mask = mask;
  entry->fn = std::move(fn);
  entry->valueFn = std::move(valueFn);
  callbacks_.emplace(id, std::move(entry));
  matchCache_.valid = false;
  return id;
}

CallbackId TupleSpace::addCallbackWithHeld(const Pattern& pattern, Callback fn) {
  return queueHeld(pattern, addCallback(pattern, kOnChange, std::move(fn)));
}

CallbackId TupleSpace::addValueCallbackWithHeld(const Pattern& pattern, ValueCallback fn) {
  return queueHeld(pattern, addValueCallback(pattern, kOnChange, std::move(fn)));
}

CallbackId TupleSpace::queueHeld(const Pattern& pattern, CallbackId id) {
  const auto& entry = callbacks_.at(id);
  for (const auto& tuple : find(pattern)) {
    Delivery delivery;
    delivery.kind_ = EventKind::Changed;
    delivery.tuple_ = tuple;
    if (!indirects_.empty()) delivery.incarnation_ = lifeOf(tuple->owner);
    delivery.targets_.emplace_back(entry.get());
    queue_.push_back(std::move(delivery));
  }
  return id;
}

CallbackId TupleSpace::addIndirectCallback(PeisId metaOwner, std::string_view metaKey,
                                           unsigned mask, Callback fn) {
  validateKey(metaKey);
  const auto id = nextCallbackId_++;
  auto indirect = std::make_shared<Indirect>();
  indirect->meta = TupleRef{metaOwner, std::string(metaKey)};
  indirect->mask = mask;
  indirect->fn = std::move(fn);
  indirects_.emplace(id, indirect);
  retarget(indirect);
  return id;
}

bool TupleSpace::removeCallback(CallbackId id) {
  if (auto it = callbacks_.find(id); it != callbacks_.end()) {
    it->second->active = false;
    // Deliveries queued or taken until now may point to it: it is kept
    // until they ran (deliveriesRan). With none, it goes now (as it did
    // when deliveries held shared references): nothing may be left to
    // wait for a drain that no event would schedule.
    const auto before = taken_ + (queue_.size() - queueHead_);
    if (before > ranThrough_) retired_.push_back(Retired{before, std::move(it->second)});
    callbacks_.erase(it);
    matchCache_ = MatchCache();
    return true;
  }
  if (auto it = indirects_.find(id); it != indirects_.end()) {
    it->second->active = false;
    indirects_.erase(it);
    return true;
  }
  return false;
}

std::optional<TupleRef> TupleSpace::indirectTarget(CallbackId id) const {
  auto it = indirects_.find(id);
  return it == indirects_.end() ? std::nullopt : it->second->queueTarget;
}

void TupleSpace::retarget(const std::shared_ptr<Indirect>& indirect) {
  auto target = resolveMeta(indirect->meta.owner, indirect->meta.key);
  if (indirect->targeted && target == indirect->queueTarget) return;
  indirect->targeted = true;
  if (retargetObserver_) {
    for (const auto& [id, entry] : indirects_) {
      if (entry == indirect) retargetObserver_(id, indirect->queueTarget, target);
    }
  }
  indirect->queueTarget = target;
  Delivery delivery;
  delivery.kind_ = EventKind::Changed;
  delivery.tuple_ = target ? get(target->owner, target->key) : nullptr;
  delivery.incarnation_ = target ? lifeOf(target->owner) : 0;
  delivery.targets_.emplace_back(indirect, std::make_shared<const std::optional<TupleRef>>(target));
  queue_.push_back(std::move(delivery));
}

const std::vector<std::shared_ptr<TupleSpace::Entry>>& TupleSpace::candidates(EventKind kind,
                                                                              const Tuple& tuple) {
  auto& cache = matchCache_;
  if (cache.valid && cache.owner == tuple.owner && cache.kind == kind &&
      sameBytes(cache.key, tuple.key)) {
    return cache.entries;
  }
  cache.entries.clear();
  for (const auto& [id, entry] : callbacks_) {
    if ((entry->mask & static_cast<unsigned>(kind)) &&
        entry->pattern.matchesOwnerAndKey(tuple.owner, tuple.key)) {
      cache.entries.push_back(entry);
    }
  }
  cache.valid = true;
  cache.owner = tuple.owner;
  cache.kind = kind;
  cache.key = tuple.key;
  return cache.entries;
}

void TupleSpace::queueEvent(EventKind kind, const TuplePtr& tuple, TuplePtr* storedIn) {
  if (observer_) observer_(kind, tuple);
  // Built in place at the end of the queue once something matches (an
  // event nothing matches, such as a stream's update nobody here watches,
  // touches no delivery).
  Delivery* delivery = nullptr;
  auto deliver = [&]() -> Delivery& {
    if (!delivery) {
      if (storedIn) settle();  // at most one delivery without a reference
      delivery = &queue_.emplace_back();
      delivery->kind_ = kind;
      if (storedIn) {
        // No reference (an atomic increment, and a decrement once the
        // value is replaced): the map's is handed over when the value
        // leaves it (release), or copied when the delivery is taken.
        unownedSlot_ = storedIn;
        unownedIndex_ = queue_.size() - 1;
      } else {
        delivery->tuple_ = tuple;
      }
      if (!indirects_.empty()) delivery->incarnation_ = lifeOf(tuple->owner);
    }
    return *delivery;
  };
  for (const auto& entry : candidates(kind, *tuple)) {
    if (entry->pattern.matchesBeyondOwnerAndKey(*tuple)) {  // its creator, mimetype or data filter
      deliver().targets_.emplace_back(entry.get());
    }
  }
  if (indirects_.empty()) return;
  // A PEIS taking, changing or losing a name can change where meta tuples
  // that name owners by name point, so every indirect callback re-resolves.
  std::vector<std::shared_ptr<Indirect>> metaWatchers;
  const bool nameEvent = tuple->key == "kernel.name";
  for (const auto& [id, indirect] : indirects_) {
    if (sameRef(indirect->queueTarget, *tuple)) deliver().targets_.emplace_back(indirect);
    if (nameEvent || (indirect->meta.owner == tuple->owner && indirect->meta.key == tuple->key)) {
      metaWatchers.push_back(indirect);
    }
  }
  for (const auto& indirect : metaWatchers) retarget(indirect);
}

static_assert(std::is_nothrow_move_constructible_v<TupleSpace::Delivery>,
              "the delivery queue moves deliveries when it grows");

std::optional<TupleSpace::Delivery> TupleSpace::nextDelivery() {
  if (queueHead_ == queue_.size()) return std::nullopt;
  settle();
  ++taken_;
  std::optional<Delivery> delivery(std::move(queue_[queueHead_++]));
  if (queueHead_ == queue_.size()) {
    queue_.clear();
    queueHead_ = 0;
  }
  return delivery;
}

void TupleSpace::takeAllDeliveries(std::vector<Delivery>& out) {
  settle();
  taken_ += queue_.size() - queueHead_;
  if (out.empty() && queueHead_ == 0) {
    out.swap(queue_);
    return;
  }
  for (auto i = queueHead_; i < queue_.size(); ++i) out.push_back(std::move(queue_[i]));
  queue_.clear();
  queueHead_ = 0;
}

void TupleSpace::deliveriesRan(RemovedCallbacks& letGo) {
  ranThrough_ = taken_;
  if (retired_.empty()) return;
  // Those retired before the last delivery taken: no delivery left points to them.
  std::erase_if(retired_, [&](Retired& r) {
    if (r.before > taken_) return false;
    letGo.push_back(std::move(r.entry));
    return true;
  });
}

std::size_t TupleSpace::dispatch() {
  if (dispatching_) return 0;
  dispatching_ = true;
  struct Reset {
    bool& flag;
    ~Reset() { flag = false; }
  } reset{dispatching_};
  std::size_t count = 0;
  while (auto delivery = nextDelivery()) {
    delivery->run();
    ++count;
  }
  return count;
}

void TupleSpace::flushAllKeys() {
  if (!allKeysDirty_) return;
  auto keys = keysOf(self_);
  if (!std::binary_search(keys.begin(), keys.end(), std::string("kernel.all-keys"))) {
    keys.insert(std::lower_bound(keys.begin(), keys.end(), std::string("kernel.all-keys")),
                "kernel.all-keys");
  }
  std::string list;
  for (const auto& key : keys) list += (list.empty() ? "" : " ") + key;
  setKernelTuple("kernel.all-keys", std::move(list));
  allKeysDirty_ = false;
}

}  // namespace peis
