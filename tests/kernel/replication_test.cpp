// Unit tests of Replication alone: a TupleSpace with a manual clock and a
// Replication over it, driven the way the Kernel drives them (the space's
// observer feeds onLocalEvent; network events call the on* methods), with
// the decisions read from takeOutbox(). No sockets, no threads, no sleeping.
#include "replication.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "net/wire.h"
#include "peis/error.h"
#include "peis/pattern.h"
#include "peis/tuple.h"
#include "support/tuples.h"
#include "support/wait_for.h"
#include "tuple_space.h"

using namespace std::chrono_literals;
using peis::ErrorCode;
using peis::EventKind;
using peis::Pattern;
using peis::PeisId;
using peis::Replication;
using peis::Tuple;
using peis::TuplePtr;
using peis::TupleRef;
using peis::TupleSpace;
namespace wire = peis::wire;

namespace {

constexpr PeisId kSelf = 1;
constexpr std::uint64_t kIncarnation = 100;
constexpr auto kLease = 6000ms;

// One message of the outbox, as the network will send it. The outbox keeps
// runs of updates as encoded frames; flatten() decodes them (checking each
// frame's envelope) so the tests see one message per update.
struct Sent {
  PeisId destination = 0;
  TuplePtr update;
  std::shared_ptr<wire::RoutedBody> body;
};

std::vector<Sent> flatten(std::vector<Replication::Outgoing>&& outbox) {
  std::vector<Sent> sent;
  for (auto& out : outbox) {
    if (out.body) sent.push_back(Sent{out.destination, nullptr, std::move(out.body)});
    if (out.update) sent.push_back(Sent{out.destination, out.update, nullptr});
    std::string_view frames = out.frames;
    std::uint32_t count = 0;
    while (!frames.empty()) {
      REQUIRE(frames.size() >= wire::kFrameHeaderBytes);
      const auto length = wire::frameLength(frames);
      REQUIRE(frames.size() >= wire::kFrameHeaderBytes + length);
      auto decoded = wire::decode(frames.substr(wire::kFrameHeaderBytes, length), 1 << 20);
      REQUIRE(decoded.message);
      auto& routed = std::get<wire::RoutedMessage>(*decoded.message);
      CHECK(routed.envelope.source == kSelf);
      CHECK(routed.envelope.destination == out.destination);
      auto& update = std::get<wire::TupleUpdate>(routed.body);
      CHECK(update.ownerIncarnation == kIncarnation);
      sent.push_back(
          Sent{out.destination, std::make_shared<const Tuple>(std::move(update.tuple)), nullptr});
      frames.remove_prefix(wire::kFrameHeaderBytes + length);
      ++count;
    }
    CHECK(count == out.frameCount);
  }
  return sent;
}

// One PEIS's space and replication, wired as the Kernel wires them.
struct Fixture {
  peis::test::ManualClock clock;
  TupleSpace space{kSelf, [this] { return clock.now; }};
  Replication replication{space, kIncarnation, kLease};
  Replication::SteadyTime now = Replication::SteadyTime{} + 1000s;

  Fixture() {
    space.setObserver(
        [this](EventKind kind, const TuplePtr& t) { replication.onLocalEvent(kind, t); });
    space.setRetargetObserver(
        [this](peis::CallbackId id, const std::optional<TupleRef>&,
               const std::optional<TupleRef>& to) { replication.onRetarget(id, to); });
  }

  std::vector<Sent> take() { return flatten(replication.takeOutbox()); }
};

wire::Subscribe subscribeMsg(std::uint64_t id, std::string pattern,
                             std::optional<PeisId> owner = kSelf,
                             std::uint32_t leaseMs = static_cast<std::uint32_t>(kLease.count())) {
  return wire::Subscribe{id, leaseMs, owner, std::move(pattern)};
}

// A renewal that says what the subscriber holds: these keys at these seqnos.
wire::Subscribe renewalMsg(std::uint64_t id, std::string pattern,
                           const std::vector<std::pair<std::string, std::uint64_t>>& held) {
  auto message = subscribeMsg(id, std::move(pattern));
  for (const auto& [key, seqno] : held) {
    ++message.knownCount;
    message.knownDigest += wire::tupleDigest(key, seqno);
  }
  return message;
}

template <typename T>
const T* bodyAs(const Sent& out) {
  if (!out.body) return nullptr;
  return std::get_if<T>(&*out.body);
}

// The KeyManifests in `outbox` for `destination`.
std::vector<wire::KeyManifest> manifests(const std::vector<Sent>& outbox, PeisId destination) {
  std::vector<wire::KeyManifest> found;
  for (const auto& out : outbox)
    if (const auto* m = bodyAs<wire::KeyManifest>(out); m && out.destination == destination)
      found.push_back(*m);
  return found;
}

// The keys of the tuple updates in `outbox` for `destination`.
std::multiset<std::string> updatedKeys(const std::vector<Sent>& outbox, PeisId destination) {
  std::multiset<std::string> keys;
  for (const auto& out : outbox) {
    if (out.destination == destination && out.update) keys.insert(out.update->key);
  }
  return keys;
}

using peis::test::remoteTuple;

wire::Write writeMsg(std::uint64_t request, wire::WriteOp op, std::string key, std::string data,
                     std::optional<std::uint64_t> ifSeqno = std::nullopt, PeisId owner = kSelf) {
  wire::Write w;
  w.request = request;
  w.op = op;
  w.ifSeqno = ifSeqno;
  w.tuple.owner = owner;
  w.tuple.creator = 9;
  w.tuple.key = std::move(key);
  w.tuple.data = std::move(data);
  return w;
}

// The one WriteResult in `outbox`, checked to go to `destination`.
wire::WriteResult onlyResult(const std::vector<Sent>& outbox, PeisId destination) {
  std::vector<wire::WriteResult> results;
  for (const auto& out : outbox) {
    if (const auto* r = bodyAs<wire::WriteResult>(out)) {
      CHECK(out.destination == destination);
      results.push_back(*r);
    }
  }
  REQUIRE(results.size() == 1);
  return results.front();
}

std::uint8_t statusOf(ErrorCode code) {
  return static_cast<std::uint8_t>(static_cast<int>(code) + 1);
}

}  // namespace

TEST_CASE("replication owner side: subscriptions, full sync, updates, leases",
          "[unit][replication]") {
  Fixture f;
  f.space.set("robot.x", "1");
  f.space.set("robot.y", "2");
  f.space.set("other.z", "3");
  CHECK(f.take().empty());  // nobody subscribed yet

  SECTION("a new subscription gets a full sync of the matching own tuples") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    const auto outbox = f.take();
    CHECK(updatedKeys(outbox, 9) == std::multiset<std::string>{"robot.x", "robot.y"});
    CHECK(outbox.size() == 2);
    for (const auto& out : outbox) CHECK_FALSE(out.body);
    CHECK(f.replication.subscribers() == std::vector<PeisId>{9});

    // Renewal with the same subscription id from a subscriber that holds
    // both values (seqnos 1 + 1): no second sync.
    f.replication.onSubscribe(9, renewalMsg(1, "robot.*", {{"robot.x", 1}, {"robot.y", 1}}),
                              f.now + 2s);
    CHECK(f.take().empty());
    CHECK(f.replication.resyncs() == 0);

    // A renewal showing a value was lost in transit: everything again, and
    // the keys held here, for the subscriber to drop what it holds beyond.
    f.replication.onSubscribe(9, renewalMsg(1, "robot.*", {{"robot.x", 1}}), f.now + 2s);
    const auto resync = f.take();
    CHECK(updatedKeys(resync, 9) == std::multiset<std::string>{"robot.x", "robot.y"});
    CHECK(f.replication.resyncs() == 1);
    const auto manifest = manifests(resync, 9);
    REQUIRE(manifest.size() == 1);
    CHECK(manifest[0].rangeFirst == 0);
    CHECK(manifest[0].rangeLast == UINT64_MAX);
    auto expected = std::vector<std::uint64_t>{wire::keyHash("robot.x"), wire::keyHash("robot.y")};
    std::sort(expected.begin(), expected.end());
    CHECK(manifest[0].keyHashes == expected);

    // A second pattern of the same subscriber is a new subscription.
    f.replication.onSubscribe(9, subscribeMsg(2, "**", std::nullopt), f.now);
    CHECK(updatedKeys(f.take(), 9) == std::multiset<std::string>{"robot.x", "robot.y", "other.z"});

    // A later own set: one update to 9 although both of its patterns match.
    f.space.set("robot.x", "10");
    auto later = f.take();
    REQUIRE(later.size() == 1);
    CHECK(later[0].destination == 9);
    REQUIRE(later[0].update);
    CHECK(later[0].update->data == "10");
    CHECK(later[0].update->seqno == 2);

    // Only the second pattern matches other.z.
    f.space.set("other.z", "30");
    CHECK(updatedKeys(f.take(), 9) == std::multiset<std::string>{"other.z"});
  }

  SECTION("every matching subscriber gets its own copy; others none") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.x"), f.now);
    f.replication.onSubscribe(4, subscribeMsg(1, "robot.**"), f.now);
    f.replication.onSubscribe(5, subscribeMsg(1, "other.*"), f.now);
    f.take();
    f.space.set("robot.x", "new");
    const auto outbox = f.take();
    CHECK(updatedKeys(outbox, 9) == std::multiset<std::string>{"robot.x"});
    CHECK(updatedKeys(outbox, 4) == std::multiset<std::string>{"robot.x"});
    CHECK(updatedKeys(outbox, 5).empty());
    CHECK(outbox.size() == 2);
  }

  SECTION("updates are encoded at once, a run per destination; takeOutbox takes entries in order") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    f.replication.onSubscribe(4, subscribeMsg(1, "robot.*"), f.now);
    f.space.set("robot.x", "later");  // extends the run of each destination
    // Destinations in the order they started waiting, each one's entries in order.
    auto first = f.replication.takeOutbox(1);
    REQUIRE(first.size() == 1);
    CHECK(first[0].destination == 9);
    CHECK(first[0].frameCount == 3);
    CHECK_FALSE(first[0].update);
    CHECK(f.replication.hasOutgoing());
    auto rest = f.take();
    REQUIRE(rest.size() == 3);
    CHECK(rest[2].destination == 4);
    CHECK(rest[2].update->data == "later");
    CHECK_FALSE(f.replication.hasOutgoing());
    CHECK(f.replication.outboxBytes() == 0);

    // A byte budget stops taking early, but always takes one entry.
    f.space.set("robot.x", "a");
    f.space.set("robot.y", "b");
    std::vector<Replication::Outgoing> some;
    f.replication.takeOutbox(some, 10, 1);
    CHECK(some.size() == 1);
    CHECK(f.replication.hasOutgoing());
  }

  SECTION("a run of frames for one destination is cut at about 64 KiB") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    f.take();
    const std::string data(1000, 'd');
    for (int i = 0; i < 100; ++i) f.space.set("robot.x", data);
    auto outbox = f.replication.takeOutbox();
    REQUIRE(outbox.size() >= 2);
    std::uint32_t frames = 0;
    for (const auto& out : outbox) {
      CHECK(out.frames.size() < Replication::kFramesPerEntryBytes + 2000);
      frames += out.frameCount;
    }
    CHECK(frames == 100);
  }

  SECTION("an overfull outbox keeps only the newest waiting update per (destination, key)") {
    f.replication.onSubscribe(9, subscribeMsg(1, "**", std::nullopt), f.now);
    f.replication.onSubscribe(4, subscribeMsg(1, "fill.*"), f.now);
    // Three synced tuples, then two updates (to 9 and 4) per distinct key,
    // until more than the coalescing threshold waits.
    const std::string big(32 * 1024, 'x');
    for (int i = 0; f.replication.outbox().bytesFor(9) < Replication::kCoalesceOutboxAbove; ++i) {
      f.space.set("fill.k" + std::to_string(i), big);
    }
    CHECK(f.replication.coalesced() == 0);
    f.space.set("robot.x", "v1");  // queued behind a full outbox: may be replaced
    f.space.set("robot.x", "v2");
    f.space.set("robot.x", "v3");
    CHECK(f.replication.coalesced() == 2);
    // Another message to 9 ends coalescing for 9: no update jumps over it.
    f.space.erase("robot.y");
    f.space.set("robot.x", "v4");
    CHECK(f.replication.coalesced() == 2);

    std::vector<std::string> toNine;
    for (const auto& out : f.take()) {
      if (out.destination != 9) continue;
      if (out.update && out.update->key == "robot.x") toNine.push_back(out.update->data);
      if (bodyAs<wire::TupleDeleted>(out))
        toNine.push_back("deleted " + bodyAs<wire::TupleDeleted>(out)->key);
    }
    CHECK(toNine == std::vector<std::string>{"1", "v3", "deleted robot.y", "v4"});
    CHECK(f.replication.outboxBytes() == 0);
  }

  SECTION("frames queued after a waiting update end coalescing into it") {
    f.replication.onSubscribe(9, subscribeMsg(1, "**", std::nullopt), f.now);
    const std::string big(32 * 1024, 'x');
    for (int i = 0; f.replication.outboxBytes() < Replication::kCoalesceOutboxAbove; ++i) {
      f.space.set("fill.k" + std::to_string(i), big);
    }
    f.space.set("robot.x", "waiting");
    // The network drains part of the outbox: below the threshold again,
    // updates are encoded at once, behind the one still waiting.
    std::vector<Replication::Outgoing> drained;
    f.replication.takeOutbox(drained, SIZE_MAX, Replication::kCoalesceOutboxAbove - 4096);
    REQUIRE(f.replication.outboxBytes() < Replication::kTrackOutboxAbove);
    f.space.set("robot.x", "encoded");
    // Backed up again: the newest value may not replace "waiting", which
    // would put it ahead of "encoded".
    for (int i = 0; f.replication.outboxBytes() < Replication::kCoalesceOutboxAbove; ++i) {
      f.space.set("more.k" + std::to_string(i), big);
    }
    f.space.set("robot.x", "newest");
    std::vector<std::string> values;
    for (const auto& out : f.take()) {
      if (out.update && out.update->key == "robot.x") values.push_back(out.update->data);
    }
    CHECK(values == std::vector<std::string>{"waiting", "encoded", "newest"});
  }

  SECTION("frames encoded with an old id are dropped when the id changes") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    f.replication.onUnsubscribe(9, 7);  // unknown: no message
    f.replication.onSelfChanged();
    CHECK_FALSE(f.replication.hasOutgoing());
    CHECK(f.replication.outboxBytes() == 0);
  }

  SECTION("a subscription for another owner is ignored") {
    f.replication.onSubscribe(9, subscribeMsg(1, "**", PeisId{5}), f.now);
    CHECK(f.take().empty());
    CHECK(f.replication.subscribers().empty());
    f.space.set("robot.x", "new");
    CHECK(f.take().empty());
  }

  SECTION("a delete is sent as TupleDeleted with the delete's seqno") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    f.take();
    REQUIRE(f.space.erase("robot.y"));
    const auto outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 9);
    CHECK_FALSE(outbox[0].update);
    const auto* deleted = bodyAs<wire::TupleDeleted>(outbox[0]);
    REQUIRE(deleted);
    CHECK(deleted->ownerIncarnation == kIncarnation);
    CHECK(deleted->owner == kSelf);
    CHECK(deleted->key == "robot.y");
    CHECK(deleted->seqno == 2);  // set was 1, the delete 2
    CHECK(deleted->seqno == f.space.seqno(kSelf, "robot.y"));

    f.space.erase("other.z");  // matches no subscription
    CHECK(f.take().empty());
  }

  SECTION("an unsubscribe stops updates") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    f.replication.onSubscribe(9, subscribeMsg(2, "other.*"), f.now);
    f.take();
    f.replication.onUnsubscribe(9, 1);
    f.space.set("robot.x", "new");
    CHECK(f.take().empty());
    CHECK(f.replication.subscribers() == std::vector<PeisId>{9});
    f.replication.onUnsubscribe(9, 2);
    CHECK(f.replication.subscribers().empty());
    f.replication.onUnsubscribe(9, 3);  // unknown: harmless
    f.replication.onUnsubscribe(8, 1);
  }

  SECTION("leases: kept while renewed, dropped once they run out") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    f.take();
    CHECK_FALSE(f.replication.expireLeases(f.now + kLease - 1ms));
    CHECK_FALSE(f.replication.expireLeases(f.now + kLease));
    // A renewal at +4 s moves the end of the lease to +10 s.
    f.replication.onSubscribe(9, renewalMsg(1, "robot.*", {{"robot.x", 1}, {"robot.y", 1}}),
                              f.now + 4s);
    CHECK(f.take().empty());
    CHECK_FALSE(f.replication.expireLeases(f.now + 4s + kLease));
    CHECK(f.replication.subscribers() == std::vector<PeisId>{9});
    CHECK(f.replication.expireLeases(f.now + 4s + kLease + 1ms));
    CHECK(f.replication.subscribers().empty());
    f.space.set("robot.x", "new");
    CHECK(f.take().empty());
    CHECK_FALSE(f.replication.expireLeases(f.now + 100s));
  }

  SECTION("a lease shorter than 300 ms is taken as 300 ms") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*", kSelf, 0), f.now);
    CHECK_FALSE(f.replication.expireLeases(f.now + 300ms));
    CHECK(f.replication.expireLeases(f.now + 301ms));
  }

  SECTION("onPeerDown forgets the peer's subscriptions") {
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    f.take();
    f.replication.onPeerDown(9);
    CHECK(f.replication.subscribers().empty());
    f.space.set("robot.x", "new");
    CHECK(f.take().empty());
  }

  SECTION("a subscriber that restarts loses its old subscriptions") {
    f.replication.onPeerUp(9, 90);
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now);
    REQUIRE(f.replication.onUpdate(9, wire::TupleUpdate{90, remoteTuple(9, "k", "v", 1)}));
    f.take();
    f.replication.onPeerUp(9, 91);
    CHECK(f.replication.subscribers().empty());
  }

  SECTION("a restarted subscriber that reuses a subscription id still gets a full sync") {
    // PEIS 9 never sent us a tuple: only its route told us its incarnation.
    // It restarts without its route ever going down, and its new life
    // numbers subscriptions from 1 again.
    f.replication.onPeerUp(9, 90);
    f.replication.onSubscribe(9, subscribeMsg(1, "other.*"), f.now);
    CHECK(updatedKeys(f.take(), 9) == std::multiset<std::string>{"other.z"});
    f.replication.onPeerUp(9, 91);
    CHECK(f.replication.subscribers().empty());
    f.take();
    f.replication.onSubscribe(9, subscribeMsg(1, "robot.*"), f.now + 1s);
    CHECK(updatedKeys(f.take(), 9) == std::multiset<std::string>{"robot.x", "robot.y"});
  }
}

TEST_CASE("replication: a renewal whose seqnos add up but whose values differ brings a resync",
          "[unit][replication]") {
  Fixture f;
  f.space.set("lock", "deploying");
  f.space.set("lock", "done");  // seqno 2
  f.space.set("event.2", "b");  // seqno 1
  f.replication.onSubscribe(9, subscribeMsg(1, "**"), f.now);
  f.take();
  // The subscriber missed "done" and the deletion of event.1: it holds
  // lock 1, event.1 1, event.2 1. The seqnos add up to 3 here and there,
  // and a count alone would not tell lock 1 + event.2 1 from lock 2.
  f.replication.onSubscribe(9, renewalMsg(1, "**", {{"lock", 1}, {"event.1", 1}, {"event.2", 1}}),
                            f.now + 2s);
  auto resync = f.take();
  CHECK(updatedKeys(resync, 9) == std::multiset<std::string>{"lock", "event.2"});
  CHECK(manifests(resync, 9).size() == 1);
  CHECK(f.replication.resyncs() == 1);
  f.replication.onSubscribe(9, renewalMsg(1, "**", {{"lock", 2}, {"event.1", 1}}), f.now + 4s);
  CHECK(updatedKeys(f.take(), 9) == std::multiset<std::string>{"lock", "event.2"});
  // Exactly what is held here: nothing.
  f.replication.onSubscribe(9, renewalMsg(1, "**", {{"lock", 2}, {"event.2", 1}}), f.now + 6s);
  CHECK(f.take().empty());
  CHECK(f.replication.resyncs() == 2);
}

TEST_CASE("replication: a key manifest drops what the owner deleted unheard, in its range only",
          "[unit][replication]") {
  Fixture f;
  f.replication.onPeerUp(2, 20);
  f.replication.subscribe(Pattern("config.**", PeisId{2}));
  f.replication.subscribe(Pattern("other.*", PeisId{2}));
  const auto sent = f.take();
  REQUIRE(sent.size() == 2);
  const auto configId = bodyAs<wire::Subscribe>(sent[0])->subscription;
  CHECK(bodyAs<wire::Subscribe>(sent[0])->knownCount == 0);  // holds nothing yet
  for (const char* key : {"config.lock", "config.event.1", "config.event.2", "other.x"})
    REQUIRE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, key, "v", 1)}));
  REQUIRE(f.replication.onWithheld(
      wire::TupleWithheld{20, 2, 10, 500, remoteTuple(2, "config.big", "", 3)}));
  std::vector<std::string> deleted;
  f.space.addCallback(Pattern("**", PeisId{2}), peis::kOnDelete,
                      [&](EventKind, const Tuple& t) { deleted.push_back(t.key); });

  // The owner holds config.lock and config.event.2 only.
  std::vector<std::uint64_t> held = {wire::keyHash("config.lock"), wire::keyHash("config.event.2")};
  std::sort(held.begin(), held.end());
  // A stale manifest (another subscription id, another life) changes nothing.
  CHECK(f.replication.onKeyManifest(2, wire::KeyManifest{20, configId + 7, 0, UINT64_MAX, held}) ==
        0);
  CHECK(f.replication.onKeyManifest(2, wire::KeyManifest{19, configId, 0, UINT64_MAX, held}) == 0);
  // A manifest of a range that holds none of the stale keys drops nothing.
  const auto event1 = wire::keyHash("config.event.1");
  const auto big = wire::keyHash("config.big");
  const auto lowest = std::min(event1, big);
  if (lowest > 0) {
    std::vector<std::uint64_t> below;
    for (auto h : held)
      if (h < lowest) below.push_back(h);
    CHECK(f.replication.onKeyManifest(2, wire::KeyManifest{20, configId, 0, lowest - 1, below}) ==
          0);
  }
  // The whole range: config.event.1 and the withheld config.big go; other.x,
  // outside the subscription's pattern, stays.
  CHECK(f.replication.onKeyManifest(2, wire::KeyManifest{20, configId, 0, UINT64_MAX, held}) == 2);
  while (auto delivery = f.space.nextDelivery()) delivery->run();
  CHECK(deleted == std::vector<std::string>{"config.event.1"});
  CHECK_FALSE(f.space.get(2, "config.event.1"));
  CHECK_FALSE(f.space.withheld(2, "config.big"));
  CHECK(f.space.get(2, "config.lock"));
  CHECK(f.space.get(2, "other.x"));
  CHECK(f.replication.manifestDrops() == 2);

  // The next Subscribe says what is held now, which the owner can check.
  f.take();
  f.replication.renew();
  for (const auto& out : f.take()) {
    const auto* renewal = bodyAs<wire::Subscribe>(out);
    REQUIRE(renewal);
    if (renewal->subscription != configId) continue;
    CHECK(renewal->knownCount == 2);
    CHECK(renewal->knownDigest ==
          wire::tupleDigest("config.lock", 1) + wire::tupleDigest("config.event.2", 1));
  }
}

TEST_CASE("replication: a full sync after a partition names the keys in ranges of 2048",
          "[unit][replication]") {
  Fixture f;
  for (int i = 0; i < 5000; ++i) f.space.set("k." + std::to_string(i), "v");
  // A fresh subscription from a PEIS that holds something already (it was
  // cut off and came back): everything, and the manifest in three parts.
  auto subscribe = renewalMsg(4, "k.*", {{"k.1", 1}, {"k.gone", 1}});
  f.replication.onSubscribe(9, subscribe, f.now);
  const auto sent = f.take();
  CHECK(updatedKeys(sent, 9).size() == 5000);
  const auto parts = manifests(sent, 9);
  REQUIRE(parts.size() == 3);
  CHECK(parts[0].rangeFirst == 0);
  CHECK(parts[2].rangeLast == UINT64_MAX);
  std::size_t hashes = 0;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    CHECK(parts[i].keyHashes.size() <= wire::kMaxManifestHashes);
    CHECK(std::is_sorted(parts[i].keyHashes.begin(), parts[i].keyHashes.end()));
    if (i > 0) CHECK(parts[i].rangeFirst == parts[i - 1].rangeLast + 1);
    hashes += parts[i].keyHashes.size();
  }
  CHECK(hashes == 5000);
  // A fresh subscription from a PEIS holding nothing gets no manifest.
  f.replication.onSubscribe(8, subscribeMsg(5, "k.*"), f.now);
  CHECK(manifests(f.take(), 8).empty());
}

TEST_CASE("replication: what a relay withheld is asked for again when the route changes",
          "[unit][replication]") {
  Fixture f;
  f.replication.onPeerUp(2, 20);
  f.replication.subscribe(Pattern("**", PeisId{2}));
  f.take();
  // One value withheld by relay 5 on the way, one by the owner for our limit.
  REQUIRE(f.replication.onWithheld(
      wire::TupleWithheld{20, 5, 64, 5000, remoteTuple(2, "picture", "", 3)}));
  REQUIRE(f.replication.onWithheld(
      wire::TupleWithheld{20, 2, 1000, 9000, remoteTuple(2, "map", "", 1)}));
  // A route change to another owner changes nothing here.
  f.replication.onRouteChanged(3);
  CHECK(f.take().empty());
  f.replication.onRouteChanged(2);
  CHECK_FALSE(f.space.withheld(2, "picture"));
  CHECK(f.space.withheld(2, "map"));  // the owner's own verdict stands
  const auto sent = f.take();
  REQUIRE(sent.size() == 1);
  const auto* renewal = bodyAs<wire::Subscribe>(sent[0]);
  REQUIRE(renewal);
  CHECK(renewal->knownCount == 1);
  CHECK(renewal->knownDigest == wire::tupleDigest("map", 1));
  // Nothing left that a relay withheld: a second change sends nothing.
  f.replication.onRouteChanged(2);
  CHECK(f.take().empty());
}

TEST_CASE("replication: a write sent again is applied once and answered again",
          "[unit][replication]") {
  Fixture f;
  // The first copy is decided (as the Kernel does: asked first, then applied).
  REQUIRE(f.replication.firstTimeWrite(9, 40));
  const auto first = f.replication.onWrite(9, writeMsg(40, wire::WriteOp::Append, "log", "a", 0u));
  CHECK(first.status == 0);
  f.take();
  // The writer missed the answer and sends the write again: not applied a
  // second time (an append on if-seqno 0 would now conflict), answered again.
  CHECK_FALSE(f.replication.firstTimeWrite(9, 40));
  CHECK(onlyResult(f.take(), 9) == first);
  CHECK(f.space.get(kSelf, "log")->data == "a");
  CHECK(f.replication.repeatedWrites() == 1);
  // The same request id from another writer is another write.
  CHECK(f.replication.firstTimeWrite(8, 40));
  // A repeat of a write still being decided (held by a write gate) is
  // ignored: the answer to the first copy answers both.
  REQUIRE(f.replication.firstTimeWrite(9, 41));
  CHECK_FALSE(f.replication.firstTimeWrite(9, 41));
  CHECK(f.take().empty());
  f.replication.refuseWrite(9, writeMsg(41, wire::WriteOp::Set, "x", "1"),
                            peis::Error(ErrorCode::Refused, "no"));
  const auto refused = onlyResult(f.take(), 9);
  CHECK_FALSE(f.replication.firstTimeWrite(9, 41));
  CHECK(onlyResult(f.take(), 9) == refused);
  // A writer cut off for a moment keeps its answers; its next life does not.
  f.replication.onPeerUp(9, 90);
  f.replication.onPeerDown(9);
  f.take();
  CHECK_FALSE(f.replication.firstTimeWrite(9, 40));
  f.take();
  f.replication.onPeerUp(9, 91);
  f.take();
  CHECK(f.replication.firstTimeWrite(9, 40));
  // Only the latest kRememberedWrites of a writer are remembered.
  for (std::uint64_t r = 1000; r < 1000 + Replication::kRememberedWrites; ++r)
    CHECK(f.replication.firstTimeWrite(7, r));
  CHECK(f.replication.firstTimeWrite(7, 2000));
  CHECK(f.replication.firstTimeWrite(7, 1000));  // forgotten: taken as new
}

TEST_CASE("replication owner side: remote writes", "[unit][replication]") {
  Fixture f;
  f.replication.onSubscribe(4, subscribeMsg(1, "**"), f.now);
  f.take();

  SECTION("set") {
    auto w = writeMsg(11, wire::WriteOp::Set, "door.open", "yes");
    w.tuple.mimetype = "text/x-bool";
    w.ttlMicros = 5'000'000;
    const auto result = f.replication.onWrite(9, w);
    CHECK(result.request == 11);
    CHECK(result.status == 0);
    CHECK(result.seqno == 1);
    const auto outbox = f.take();
    CHECK(onlyResult(outbox, 9) == result);
    CHECK(updatedKeys(outbox, 4) == std::multiset<std::string>{"door.open"});
    const auto stored = f.space.get(kSelf, "door.open");
    REQUIRE(stored);
    CHECK(stored->data == "yes");
    CHECK(stored->creator == 9);
    CHECK(stored->owner == kSelf);
    CHECK(stored->mimetype == "text/x-bool");
    CHECK(stored->ts_expire == f.clock.now + 5s);
  }

  SECTION("append, with an if-seqno that holds and one that no longer does") {
    auto r1 = f.replication.onWrite(9, writeMsg(1, wire::WriteOp::Append, "log", "a"));
    CHECK(r1.status == 0);
    CHECK(r1.seqno == 1);
    auto r2 = f.replication.onWrite(9, writeMsg(2, wire::WriteOp::Append, "log", "b", 1u));
    CHECK(r2.status == 0);
    CHECK(r2.seqno == 2);
    CHECK(f.space.get(kSelf, "log")->data == "ab");
    f.take();

    auto conflict = f.replication.onWrite(9, writeMsg(3, wire::WriteOp::Append, "log", "c", 1u));
    CHECK(conflict.request == 3);
    CHECK(conflict.status == statusOf(ErrorCode::Conflict));
    CHECK(conflict.seqno == 0);
    CHECK_FALSE(conflict.message.empty());
    CHECK(f.space.get(kSelf, "log")->data == "ab");
    const auto outbox = f.take();
    CHECK(onlyResult(outbox, 9) == conflict);
    CHECK(updatedKeys(outbox, 4).empty());

    // if-seqno 0: only while the key does not exist.
    CHECK(f.replication.onWrite(9, writeMsg(4, wire::WriteOp::Append, "fresh", "x", 0u)).status ==
          0);
    CHECK(f.replication.onWrite(9, writeMsg(5, wire::WriteOp::Append, "fresh", "y", 0u)).status ==
          statusOf(ErrorCode::Conflict));
  }

  SECTION("erase") {
    f.space.set("gone", "x");
    f.take();
    const auto result = f.replication.onWrite(9, writeMsg(6, wire::WriteOp::Erase, "gone", ""));
    CHECK(result.status == 0);
    CHECK(result.seqno == 2);
    CHECK_FALSE(f.space.get(kSelf, "gone"));
    const auto outbox = f.take();
    CHECK(onlyResult(outbox, 9) == result);
    bool deleteSent = false;
    for (const auto& out : outbox) {
      if (const auto* d = bodyAs<wire::TupleDeleted>(out)) {
        deleteSent = out.destination == 4 && d->key == "gone" && d->seqno == 2;
      }
    }
    CHECK(deleteSent);

    // Erasing what is absent succeeds with seqno 0.
    const auto absent = f.replication.onWrite(9, writeMsg(7, wire::WriteOp::Erase, "never", ""));
    CHECK(absent.status == 0);
    CHECK(absent.seqno == 0);
  }

  SECTION("a write for another owner is refused") {
    const auto result = f.replication.onWrite(9, writeMsg(8, wire::WriteOp::Set, "k", "v", {}, 5));
    CHECK(result.request == 8);
    CHECK(result.status == statusOf(ErrorCode::Refused));
    CHECK(result.message.find("does not own") != std::string::npos);
    CHECK(f.space.size() == 0);
    CHECK(onlyResult(f.take(), 9) == result);
  }

  SECTION("a write the space rejects reports the space's error") {
    auto w = writeMsg(9, wire::WriteOp::Set, "k", "v");
    w.tuple.mimetype = std::string(peis::kMaxMimetypeBytes + 1, 'm');
    const auto result = f.replication.onWrite(9, w);
    CHECK(result.status == statusOf(ErrorCode::InvalidArgument));
    CHECK(f.space.size() == 0);
  }
}

TEST_CASE("replication subscriber side", "[unit][replication]") {
  Fixture f;
  f.replication.onPeerUp(2, 20);
  f.replication.onPeerUp(3, 30);
  CHECK(f.take().empty());  // nothing subscribed yet

  const auto any = f.replication.subscribe(Pattern("x.**"));
  auto outbox = f.take();
  REQUIRE(outbox.size() == 2);
  std::map<PeisId, std::uint64_t> anyIds;
  for (const auto& out : outbox) {
    const auto* s = bodyAs<wire::Subscribe>(out);
    REQUIRE(s);
    CHECK_FALSE(s->owner);
    CHECK(s->keyPattern == "x.**");
    CHECK(s->leaseMs == kLease.count());
    anyIds[out.destination] = s->subscription;
  }
  REQUIRE(anyIds.size() == 2);
  CHECK(anyIds.count(2));
  CHECK(anyIds.count(3));
  CHECK(anyIds[2] != anyIds[3]);

  SECTION("an owner-specific subscription goes to that owner only") {
    f.replication.subscribe(Pattern("k", PeisId{3}));
    outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 3);
    const auto* s = bodyAs<wire::Subscribe>(outbox[0]);
    REQUIRE(s);
    CHECK(s->owner == PeisId{3});
    CHECK(s->keyPattern == "k");

    f.replication.subscribe(Pattern("k", kSelf));      // own tuples: nothing to send
    f.replication.subscribe(Pattern("k", PeisId{8}));  // unreachable owner: later
    CHECK(f.take().empty());
    f.replication.onPeerUp(8, 80);
    outbox = f.take();
    std::set<std::string> toEight;
    for (const auto& out : outbox) {
      CHECK(out.destination == 8);
      if (const auto* sub = bodyAs<wire::Subscribe>(out)) toEight.insert(sub->keyPattern);
    }
    CHECK(toEight == std::set<std::string>{"x.**", "k"});
  }

  SECTION("a new peer gets a Subscribe") {
    f.replication.onPeerUp(4, 40);
    outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 4);
    const auto* s = bodyAs<wire::Subscribe>(outbox[0]);
    REQUIRE(s);
    CHECK(s->keyPattern == "x.**");
    CHECK(s->subscription != anyIds[2]);
    CHECK(s->subscription != anyIds[3]);
  }

  SECTION("renew re-sends every subscription with the same id") {
    f.replication.renew();
    outbox = f.take();
    REQUIRE(outbox.size() == 2);
    for (const auto& out : outbox) {
      const auto* s = bodyAs<wire::Subscribe>(out);
      REQUIRE(s);
      CHECK(s->subscription == anyIds[out.destination]);
    }
  }

  SECTION("updates: newer seqnos accepted, stale ones rejected") {
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.a", "5", 5)}));
    CHECK(f.space.get(2, "x.a")->data == "5");
    const auto staleBefore = f.replication.staleDropped();
    CHECK_FALSE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.a", "4", 4)}));
    CHECK_FALSE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.a", "5b", 5)}));
    CHECK(f.space.get(2, "x.a")->data == "5");
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.a", "6", 6)}));
    CHECK(f.space.get(2, "x.a")->data == "6");
    CHECK(f.replication.staleDropped() == staleBefore);  // stale seqnos are the space's call

    // Deletes follow the same order.
    CHECK_FALSE(f.replication.onDeleted(2, wire::TupleDeleted{20, 2, "x.a", 6}));
    CHECK(f.space.get(2, "x.a"));
    CHECK(f.replication.onDeleted(2, wire::TupleDeleted{20, 2, "x.a", 7}));
    CHECK_FALSE(f.space.get(2, "x.a"));
    CHECK(f.take().empty());  // nothing is sent back for others' tuples
  }

  SECTION("an update or delete whose owner is not the source is rejected") {
    const auto before = f.replication.staleDropped();
    CHECK_FALSE(f.replication.onUpdate(3, wire::TupleUpdate{30, remoteTuple(2, "x.a", "s", 1)}));
    CHECK_FALSE(f.space.get(2, "x.a"));
    CHECK(f.replication.staleDropped() == before + 1);
    REQUIRE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.a", "v", 1)}));
    CHECK_FALSE(f.replication.onDeleted(3, wire::TupleDeleted{30, 2, "x.a", 9}));
    CHECK(f.space.get(2, "x.a"));
    CHECK(f.replication.staleDropped() == before + 2);
  }

  SECTION("an update of our own tuple is rejected") {
    f.space.set("x.mine", "local");
    f.take();
    CHECK_FALSE(f.replication.onUpdate(
        kSelf, wire::TupleUpdate{kIncarnation, remoteTuple(kSelf, "x.mine", "r", 9)}));
    CHECK(f.space.get(kSelf, "x.mine")->data == "local");
  }

  SECTION("owner incarnations: newer forgets the old tuples, older is dropped") {
    REQUIRE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.a", "a", 5)}));
    REQUIRE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.b", "b", 5)}));
    REQUIRE(f.replication.onUpdate(3, wire::TupleUpdate{30, remoteTuple(3, "x.a", "3", 5)}));

    // PEIS 2 restarted: its seqnos start again at 1.
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{21, remoteTuple(2, "x.a", "new", 1)}));
    CHECK(f.space.get(2, "x.a")->data == "new");
    CHECK_FALSE(f.space.get(2, "x.b"));         // forgotten with the old life
    CHECK(f.space.get(3, "x.a")->data == "3");  // other owners untouched

    const auto before = f.replication.staleDropped();
    CHECK_FALSE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.b", "old", 99)}));
    CHECK_FALSE(f.space.get(2, "x.b"));
    CHECK_FALSE(f.replication.onDeleted(2, wire::TupleDeleted{20, 2, "x.a", 99}));
    CHECK(f.space.get(2, "x.a"));
    CHECK(f.replication.staleDropped() == before + 2);
  }

  SECTION("a peer back with a new incarnation is re-subscribed with a fresh id") {
    REQUIRE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.a", "a", 5)}));
    f.replication.onPeerUp(2, 22);
    CHECK_FALSE(f.space.get(2, "x.a"));  // the old life's tuples are gone
    outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 2);
    const auto* s = bodyAs<wire::Subscribe>(outbox[0]);
    REQUIRE(s);
    CHECK(s->subscription != anyIds[2]);
    CHECK(s->subscription != anyIds[3]);
    // Updates of the old incarnation that were still in flight are dropped.
    CHECK_FALSE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x.a", "a", 6)}));
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{22, remoteTuple(2, "x.a", "b", 1)}));

    f.replication.renew();
    for (const auto& out : f.take()) {
      if (out.destination == 2)
        CHECK(bodyAs<wire::Subscribe>(out)->subscription == s->subscription);
    }
  }

  SECTION("a peer that went down is not subscribed to") {
    f.replication.onPeerDown(3);
    f.replication.renew();
    outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 2);
    f.replication.subscribe(Pattern("y"));
    outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 2);
  }

  SECTION("unsubscribe sends Unsubscribe with each owner's id") {
    CHECK(f.replication.unsubscribe(any));
    outbox = f.take();
    REQUIRE(outbox.size() == 2);
    for (const auto& out : outbox) {
      const auto* u = bodyAs<wire::Unsubscribe>(out);
      REQUIRE(u);
      CHECK(u->subscription == anyIds[out.destination]);
    }
    CHECK_FALSE(f.replication.unsubscribe(any));
    CHECK(f.take().empty());
    f.replication.renew();
    CHECK(f.take().empty());
    f.replication.onPeerUp(5, 50);
    CHECK(f.take().empty());
  }

  SECTION("onRetarget follows an indirect callback's target") {
    constexpr peis::CallbackId kIndirect = 77;
    f.replication.onRetarget(kIndirect, TupleRef{2, "target.a"});
    outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 2);
    const auto* first = bodyAs<wire::Subscribe>(outbox[0]);
    REQUIRE(first);
    CHECK(first->owner == PeisId{2});
    CHECK(first->keyPattern == "target.a");
    const auto firstId = first->subscription;

    // Re-pointed to another owner: subscribe there, unsubscribe the old one.
    f.replication.onRetarget(kIndirect, TupleRef{3, "target.b"});
    outbox = f.take();
    REQUIRE(outbox.size() == 2);
    bool unsubscribedOld = false, subscribedNew = false;
    for (const auto& out : outbox) {
      if (const auto* u = bodyAs<wire::Unsubscribe>(out)) {
        unsubscribedOld = out.destination == 2 && u->subscription == firstId;
      } else if (const auto* s = bodyAs<wire::Subscribe>(out)) {
        subscribedNew =
            out.destination == 3 && s->owner == PeisId{3} && s->keyPattern == "target.b";
      }
    }
    CHECK(unsubscribedOld);
    CHECK(subscribedNew);

    // Re-pointed at an own tuple: nothing remote to follow.
    f.replication.onRetarget(kIndirect, TupleRef{kSelf, "local"});
    outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 3);
    CHECK(bodyAs<wire::Unsubscribe>(outbox[0]));

    f.replication.onRetarget(kIndirect, TupleRef{2, "target.c"});
    f.take();
    f.replication.onRetarget(kIndirect, std::nullopt);  // points nowhere
    outbox = f.take();
    REQUIRE(outbox.size() == 1);
    CHECK(outbox[0].destination == 2);
    CHECK(bodyAs<wire::Unsubscribe>(outbox[0]));

    // A removed indirect callback ends its subscriptions, meta included.
    f.replication.onRetarget(kIndirect, TupleRef{2, "target.d"});
    f.replication.trackIndirectMeta(kIndirect, TupleRef{3, "meta.m"});
    outbox = f.take();
    REQUIRE(outbox.size() == 2);
    f.replication.onIndirectRemoved(kIndirect);
    outbox = f.take();
    std::set<PeisId> unsubscribed;
    for (const auto& out : outbox) {
      if (bodyAs<wire::Unsubscribe>(out)) unsubscribed.insert(out.destination);
    }
    CHECK(unsubscribed == std::set<PeisId>{2, 3});
  }
}

// A publisher restarted with the same id numbers its values from 1 again: its
// new life must reach an indirect callback at once, not once its seqnos pass
// those of the old life (issue 9).
TEST_CASE("replication: a restarted owner's values reach an indirect callback at once",
          "[unit][replication]") {
  Fixture f;
  f.replication.onPeerUp(2, 20);
  f.space.setMeta("mi-x", TupleRef{2, "x"});
  std::vector<std::string> seen;
  f.space.addIndirectCallback(kSelf, "mi-x", peis::kOnChange,
                              [&](EventKind, const Tuple& t) { seen.push_back(t.data); });
  for (std::uint64_t n = 1; n <= 50; ++n) {
    REQUIRE(f.replication.onUpdate(
        2, wire::TupleUpdate{20, remoteTuple(2, "x", "old-" + std::to_string(n), n)}));
  }
  f.space.dispatch();
  REQUIRE_FALSE(seen.empty());
  CHECK(seen.back() == "old-50");
  seen.clear();

  SECTION("the new life is learnt from its first update") {
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{30, remoteTuple(2, "x", "new-1", 1)}));
    f.space.dispatch();
    CHECK(seen == std::vector<std::string>{"new-1"});
    // A value of the old life still in flight is dropped and not delivered.
    CHECK_FALSE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x", "old", 51)}));
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{30, remoteTuple(2, "x", "new-2", 2)}));
    f.space.dispatch();
    CHECK(seen == std::vector<std::string>{"new-1", "new-2"});
  }

  SECTION("the new life is learnt from the route first") {
    f.replication.onPeerUp(2, 30);
    CHECK_FALSE(f.space.get(2, "x"));  // the old life's value is gone
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{30, remoteTuple(2, "x", "new-1", 1)}));
    f.space.dispatch();
    CHECK(seen == std::vector<std::string>{"new-1"});
  }

  SECTION("the old life's value had expired before the restart") {
    auto expiring = remoteTuple(2, "x", "old-51", 51);
    expiring.ts_expire = f.clock.now + 1s;
    REQUIRE(f.replication.onUpdate(2, wire::TupleUpdate{20, std::move(expiring)}));
    f.clock.advance(2s);
    CHECK(f.space.expire() == 1);
    f.space.dispatch();
    seen.clear();
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{30, remoteTuple(2, "x", "new-1", 1)}));
    f.space.dispatch();
    CHECK(seen == std::vector<std::string>{"new-1"});
  }

  SECTION("a re-created value of the same life is still delivered once") {
    CHECK(f.replication.onDeleted(2, wire::TupleDeleted{20, 2, "x", 51}));
    CHECK(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x", "again", 52)}));
    CHECK_FALSE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "x", "dup", 52)}));
    f.space.dispatch();
    CHECK(seen == std::vector<std::string>{"again"});
  }
}

// A value over a subscriber's data limit (issue 9): the owner sends what the
// subscriber needs to know instead of a frame it would have to drop.
TEST_CASE("replication: a value over the subscriber's limit is sent as TupleWithheld",
          "[unit][replication]") {
  Fixture f;
  f.space.set("big", std::string(5000, 'x'));
  f.space.set("small", "fits");
  f.take();
  auto limited = subscribeMsg(1, "**");
  limited.maxDataBytes = 1000;
  f.replication.onSubscribe(9, limited, f.now);
  auto outbox = f.take();
  CHECK(updatedKeys(outbox, 9) == std::multiset<std::string>{"small"});
  std::vector<wire::TupleWithheld> notices;
  for (const auto& out : outbox) {
    if (const auto* w = bodyAs<wire::TupleWithheld>(out)) {
      CHECK(out.destination == 9);
      notices.push_back(*w);
    }
  }
  REQUIRE(notices.size() == 1);
  CHECK(notices[0].ownerIncarnation == kIncarnation);
  CHECK(notices[0].limitedBy == 9);
  CHECK(notices[0].limit == 1000);
  CHECK(notices[0].dataBytes == 5000);
  CHECK(notices[0].tuple.key == "big");
  CHECK(notices[0].tuple.seqno == 1);
  CHECK(notices[0].tuple.data.empty());

  // Changes follow the same rule; a subscriber without a limit gets the value.
  f.replication.onSubscribe(8, subscribeMsg(2, "**"), f.now);
  f.take();
  f.space.set("big", std::string(6000, 'y'));
  outbox = f.take();
  CHECK(updatedKeys(outbox, 8) == std::multiset<std::string>{"big"});
  CHECK(updatedKeys(outbox, 9).empty());
  std::size_t toNine = 0;
  for (const auto& out : outbox) {
    if (const auto* w = bodyAs<wire::TupleWithheld>(out)) {
      CHECK(out.destination == 9);
      CHECK(w->dataBytes == 6000);
      ++toNine;
    }
  }
  CHECK(toNine == 1);
}

TEST_CASE("replication: the subscriber side takes a TupleWithheld from the owner or a relay",
          "[unit][replication]") {
  Fixture f;
  f.replication.onPeerUp(2, 20);
  f.replication.subscribe(Pattern("**", PeisId{2}));
  const auto sent = f.take();
  REQUIRE(sent.size() == 1);
  // Our Subscribe tells the owner our limit.
  CHECK(bodyAs<wire::Subscribe>(sent[0])->maxDataBytes == peis::kDefaultMaxDataBytes);

  REQUIRE(f.replication.onUpdate(2, wire::TupleUpdate{20, remoteTuple(2, "big", "small", 1)}));
  auto head = remoteTuple(2, "big", "", 2);
  CHECK(f.replication.onWithheld(wire::TupleWithheld{20, 5, 1000, 5000, head}));
  CHECK_FALSE(f.space.get(2, "big"));
  REQUIRE(f.space.withheld(2, "big"));
  CHECK(f.space.withheld(2, "big")->limitedBy == 5);
  const auto before = f.replication.staleDropped();
  CHECK_FALSE(f.replication.onWithheld(wire::TupleWithheld{19, 5, 1000, 5000, head}));
  CHECK(f.replication.staleDropped() == before + 1);

  // A renewal counts what it knows of, held or withheld: no resync for it.
  f.replication.renew();
  const auto renewals = f.take();
  REQUIRE(renewals.size() == 1);
  CHECK(bodyAs<wire::Subscribe>(renewals[0])->knownCount == 1);
  CHECK(bodyAs<wire::Subscribe>(renewals[0])->knownDigest == wire::tupleDigest("big", 2));
}

TEST_CASE("replication: a stream of one key reaches exactly the subscribers of the moment",
          "[unit][replication]") {
  // The recipients of the last key are kept between events: every change of
  // the subscriptions (new, unsubscribed, expired, a peer gone) must count.
  Fixture f;
  f.space.set("stream", "0");
  f.replication.onPeerUp(7, 1);
  f.replication.onPeerUp(8, 1);
  f.replication.onSubscribe(7, subscribeMsg(1, "stream"), f.now);
  f.take();
  f.space.set("stream", "1");
  CHECK(updatedKeys(f.take(), 8).empty());

  f.replication.onSubscribe(8, subscribeMsg(1, "**"), f.now);
  f.take();  // its full sync
  f.space.set("stream", "2");
  auto out = f.take();
  CHECK(updatedKeys(out, 7).size() == 1);
  CHECK(updatedKeys(out, 8).size() == 1);

  f.replication.onUnsubscribe(7, 1);
  f.space.set("stream", "3");
  out = f.take();
  CHECK(updatedKeys(out, 7).empty());
  CHECK(updatedKeys(out, 8).size() == 1);

  f.replication.onPeerDown(8);
  f.space.set("stream", "4");
  CHECK(f.take().empty());

  f.replication.onSubscribe(7, subscribeMsg(2, "stream"), f.now);
  f.take();
  f.space.set("stream", "5");
  CHECK(updatedKeys(f.take(), 7).size() == 1);
  CHECK(f.replication.expireLeases(f.now + kLease + 1s));
  f.space.set("stream", "6");
  CHECK(f.take().empty());
}

TEST_CASE("replication: received updates of a stream arrive whole, in order, each with its data",
          "[unit][replication]") {
  // Stored tuples and decoded data buffers are reused (docs/architecture.md,
  // "Memory of a stream"): every delivered value must still be its own.
  Fixture f;
  std::vector<std::string> seen;
  f.space.addCallback(Pattern("s"), peis::kOnChange,
                      [&](EventKind, const Tuple& t) { seen.push_back(t.data); });
  f.replication.onPeerUp(5, 1);
  std::vector<TuplePtr> held;
  for (std::uint64_t round = 0; round < 3; ++round) {
    for (std::uint64_t i = 1; i <= 40; ++i) {
      const auto seqno = round * 40 + i;
      // Sizes around the small-string limit and the reused buffers' size.
      const std::string data(static_cast<std::size_t>(seqno % 37) + 1,
                             static_cast<char>('a' + seqno % 26));
      wire::RoutedMessage routed{wire::Envelope{5, kSelf, wire::kDefaultTtl},
                                 wire::TupleUpdate{1, remoteTuple(5, "s", data, seqno)}};
      const auto frame = wire::encodeFrame(routed);
      wire::RoutedMessage decoded;
      std::string error;
      REQUIRE(wire::decodeRouted(std::string_view(frame).substr(wire::kFrameHeaderBytes), 1 << 20,
                                 decoded, error));
      CHECK(f.replication.onUpdate(5, std::move(std::get<wire::TupleUpdate>(decoded.body))));
      if (i % 10 == 0) held.push_back(f.space.get(5, "s"));  // a reader keeps a copy
    }
    // Deliveries run and their tuples go back to the space, as drain does.
    std::vector<TuplePtr> spent;
    while (auto delivery = f.space.nextDelivery()) {
      delivery->run();
      spent.push_back(delivery->takeTuple());
    }
    f.space.recycle(spent);
  }
  REQUIRE(seen.size() == 120);
  for (std::uint64_t seqno = 1; seqno <= 120; ++seqno) {
    CHECK(seen[seqno - 1] == std::string(static_cast<std::size_t>(seqno % 37) + 1,
                                         static_cast<char>('a' + seqno % 26)));
  }
  // A tuple someone holds is never written again.
  for (std::size_t k = 0; k < held.size(); ++k) {
    const auto seqno = (k / 4) * 40 + (k % 4 + 1) * 10;
    CHECK(held[k]->seqno == seqno);
    CHECK(held[k]->data == std::string(static_cast<std::size_t>(seqno % 37) + 1,
                                       static_cast<char>('a' + seqno % 26)));
  }
}
