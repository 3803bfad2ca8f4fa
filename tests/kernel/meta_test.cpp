// Unit tests of meta tuples in TupleSpace: declaring, pointing and resolving
// them, and indirect callbacks that follow whatever a meta tuple points to.
#include <catch2/catch.hpp>
#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "peis/error.h"
#include "peis/key.h"
#include "peis/pattern.h"
#include "peis/tuple.h"
#include "peis/types.h"
#include "support/error_matchers.h"
#include "support/tuples.h"
#include "support/wait_for.h"
#include "tuple_space.h"

using namespace std::chrono_literals;
using peis::Error;
using peis::ErrorCode;
using peis::EventKind;
using peis::Pattern;
using peis::Timestamp;
using peis::Tuple;
using peis::TupleRef;
using peis::TupleSpace;
using peis::test::ManualClock;

namespace {

constexpr peis::PeisId kSelf = 7;

using peis::test::HasCode;

using peis::test::remoteTuple;

Tuple remoteMeta(peis::PeisId owner, std::string key, std::string pointsTo, std::uint64_t seqno) {
  return remoteTuple(owner, std::move(key), std::move(pointsTo), seqno, peis::kMetaMimetype);
}

peis::WriteOptions metaOptions() {
  peis::WriteOptions options;
  options.mimetype = peis::kMetaMimetype;
  return options;
}

struct Seen {
  EventKind kind;
  std::string name;  // OWNER.KEY
  std::string data;
  std::uint64_t seqno;
  bool operator==(const Seen&) const = default;
};

std::ostream& operator<<(std::ostream& os, const Seen& seen) {
  return os << "{" << (seen.kind == EventKind::Changed ? "changed" : "deleted") << " " << seen.name
            << "='" << seen.data << "' #" << seen.seqno << "}";
}

struct Recorder {
  std::vector<Seen> seen;
  peis::Callback make() {
    return [this](EventKind kind, const Tuple& tuple) {
      seen.push_back(Seen{kind, tuple.fullName(), tuple.data, tuple.seqno});
    };
  }
  // The deliveries since the last call.
  std::vector<Seen> take() {
    auto out = std::move(seen);
    seen.clear();
    return out;
  }
};

// "OWNER.KEY" of a resolved target, "none" when unresolved: readable in failures.
std::string str(const std::optional<TupleRef>& ref) { return ref ? ref->str() : "none"; }

Seen changed(std::string name, std::string data, std::uint64_t seqno) {
  return Seen{EventKind::Changed, std::move(name), std::move(data), seqno};
}

}  // namespace

TEST_CASE("declareMeta creates an empty meta tuple once", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });

  space.declareMeta("robot.goal");
  auto meta = space.get(kSelf, "robot.goal");
  REQUIRE(meta);
  CHECK(meta->data.empty());
  CHECK(meta->mimetype == peis::kMetaMimetype);
  CHECK(meta->seqno == 1);
  CHECK_FALSE(space.resolveMeta(kSelf, "robot.goal"));
  CHECK(space.getIndirect(kSelf, "robot.goal") == nullptr);

  space.declareMeta("robot.goal");
  CHECK(space.seqno(kSelf, "robot.goal") == 1);

  space.setMeta("robot.goal", TupleRef{kSelf, "goal.a"});
  space.declareMeta("robot.goal");
  meta = space.get(kSelf, "robot.goal");
  CHECK(meta->data == "7.goal.a");
  CHECK(meta->seqno == 2);

  REQUIRE_THROWS_MATCHES(space.declareMeta("bad..key"), Error, HasCode(ErrorCode::InvalidKey));
}

TEST_CASE("setMeta points at a tuple that resolveMeta and getIndirect follow", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });

  CHECK_FALSE(space.resolveMeta(kSelf, "m"));  // no meta tuple at all
  CHECK(space.getIndirect(kSelf, "m") == nullptr);

  auto meta = space.setMeta("m", TupleRef{kSelf, "target.x"});
  CHECK(meta->data == "7.target.x");
  CHECK(meta->mimetype == peis::kMetaMimetype);
  CHECK(meta->owner == kSelf);
  CHECK(str(space.resolveMeta(kSelf, "m")) == "7.target.x");
  CHECK(space.getIndirect(kSelf, "m") == nullptr);  // the target has no value yet

  space.set("target.x", "42");
  auto value = space.getIndirect(kSelf, "m");
  REQUIRE(value);
  CHECK(value->data == "42");
  CHECK(value->key == "target.x");

  // Re-pointed at a remote tuple.
  REQUIRE(space.accept(remoteTuple(9, "pos", "remote", 3)));
  space.setMeta("m", TupleRef{9, "pos"});
  CHECK(str(space.resolveMeta(kSelf, "m")) == "9.pos");
  CHECK(space.getIndirect(kSelf, "m")->data == "remote");

  // Bad targets are refused and leave the meta tuple as it was.
  REQUIRE_THROWS_MATCHES(space.setMeta("m", TupleRef{0, "x"}), Error,
                         HasCode(ErrorCode::InvalidArgument));
  REQUIRE_THROWS_MATCHES(space.setMeta("m", TupleRef{9, "a..b"}), Error,
                         HasCode(ErrorCode::InvalidKey));
  REQUIRE_THROWS_MATCHES(space.setMeta("m..", TupleRef{9, "x"}), Error,
                         HasCode(ErrorCode::InvalidKey));
  CHECK(space.get(kSelf, "m")->data == "9.pos");
  CHECK(space.seqno(kSelf, "m") == 2);

  // A meta tuple of another owner resolves the same way.
  REQUIRE(space.accept(remoteMeta(9, "their.meta", "7.target.x", 1)));
  CHECK(str(space.resolveMeta(9, "their.meta")) == "7.target.x");
  CHECK(space.getIndirect(9, "their.meta")->data == "42");
}

TEST_CASE("a meta tuple may name its target's owner by name", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  REQUIRE(space.accept(remoteTuple(20, "kernel.name", "Astrid", 1)));
  REQUIRE(space.accept(remoteTuple(20, "position", "1,2", 5)));

  space.set("m", "Astrid.position", metaOptions());
  CHECK(str(space.resolveMeta(kSelf, "m")) == "20.position");
  auto value = space.getIndirect(kSelf, "m");
  REQUIRE(value);
  CHECK(value->data == "1,2");
  CHECK(value->owner == 20);

  // An unknown name resolves to nothing.
  space.set("m", "Nobody.position", metaOptions());
  CHECK_FALSE(space.resolveMeta(kSelf, "m"));
  CHECK(space.getIndirect(kSelf, "m") == nullptr);

  // An ambiguous name resolves to nothing.
  space.set("m", "Astrid.position", metaOptions());
  REQUIRE(space.accept(remoteTuple(21, "kernel.name", "Astrid", 1)));
  CHECK_FALSE(space.resolveMeta(kSelf, "m"));
  CHECK(space.getIndirect(kSelf, "m") == nullptr);
}

TEST_CASE("a meta tuple holding garbage resolves to nothing", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  space.set("target", "value");
  for (const std::string garbage :
       {"garbage", "7.", ".target", "7", "7.a..b", "7.a*b", "0.target", "99999999999.target",
        "Nobody.target", "bad name.target", "-7.target"}) {
    INFO("meta data '" << garbage << "'");
    space.set("m", garbage, metaOptions());
    CHECK_FALSE(space.resolveMeta(kSelf, "m"));
    CHECK(space.getIndirect(kSelf, "m") == nullptr);
  }
  space.set("m", "7.target", metaOptions());
  CHECK(space.getIndirect(kSelf, "m")->data == "value");
}

TEST_CASE("an expired meta tuple or target resolves to nothing", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  peis::WriteOptions ttl;
  ttl.ttl = 1s;
  space.set("target", "v", ttl);
  space.setMeta("m", TupleRef{kSelf, "target"});
  CHECK(space.getIndirect(kSelf, "m") != nullptr);
  clock.advance(1s);
  CHECK(str(space.resolveMeta(kSelf, "m")) == "7.target");
  CHECK(space.getIndirect(kSelf, "m") == nullptr);

  auto meta = remoteMeta(9, "m", "7.other", 1);
  meta.ts_expire = clock.now + 1s;
  REQUIRE(space.accept(meta));
  space.set("other", "o");
  CHECK(space.getIndirect(9, "m")->data == "o");
  clock.advance(1s);
  CHECK_FALSE(space.resolveMeta(9, "m"));
}

TEST_CASE("an indirect callback delivers the current value, then updates", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.set("target", "v1");
  space.set("target", "v2");
  space.setMeta("m", TupleRef{kSelf, "target"});

  auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
  CHECK(rec.seen.empty());  // nothing runs before dispatch
  CHECK(space.hasPendingDeliveries());
  CHECK(str(space.indirectTarget(id)) == "7.target");
  CHECK(space.dispatch() == 1);
  CHECK(rec.take() == std::vector<Seen>{changed("7.target", "v2", 2)});

  space.set("target", "v3");
  space.set("unrelated", "x");
  space.set("target", "v4");
  space.dispatch();
  CHECK(rec.take() ==
        std::vector<Seen>{changed("7.target", "v3", 3), changed("7.target", "v4", 4)});

  // Rewriting the meta tuple with the same target is no re-point.
  space.setMeta("m", TupleRef{kSelf, "target"});
  space.dispatch();
  CHECK(rec.seen.empty());

  space.erase("target");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{{EventKind::Deleted, "7.target", "v4", 5}});
  space.set("target", "v6");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.target", "v6", 6)});

  CHECK(str(space.indirectTarget(9999)) == "none");
  REQUIRE_THROWS_MATCHES(space.addIndirectCallback(kSelf, "a..b", peis::kOnAny, rec.make()), Error,
                         HasCode(ErrorCode::InvalidKey));
}

TEST_CASE("an indirect callback honours its mask", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  space.set("target", "v1");
  space.setMeta("m", TupleRef{kSelf, "target"});
  Recorder changes;
  Recorder deletes;
  space.addIndirectCallback(kSelf, "m", peis::kOnChange, changes.make());
  space.addIndirectCallback(kSelf, "m", peis::kOnDelete, deletes.make());
  space.dispatch();
  space.set("target", "v2");
  space.erase("target");
  space.set("target", "v4");
  space.dispatch();
  CHECK(changes.seen == std::vector<Seen>{changed("7.target", "v1", 1),
                                          changed("7.target", "v2", 2),
                                          changed("7.target", "v4", 4)});
  CHECK(deletes.seen == std::vector<Seen>{{EventKind::Deleted, "7.target", "v2", 3}});
}

TEST_CASE("an indirect callback registered before its meta tuple exists", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.set("target", "t");
  auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
  space.dispatch();
  CHECK(rec.seen.empty());
  CHECK(str(space.indirectTarget(id)) == "none");

  space.declareMeta("m");
  space.set("target", "t2");
  space.dispatch();
  CHECK(rec.seen.empty());

  space.setMeta("m", TupleRef{kSelf, "target"});
  CHECK(str(space.indirectTarget(id)) == "7.target");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.target", "t2", 2)});
}

TEST_CASE("re-pointing an indirect callback switches targets cleanly", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.set("a", "a1");
  space.set("b", "b1");
  space.setMeta("m", TupleRef{kSelf, "a"});
  auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.a", "a1", 1)});

  space.set("a", "a2");
  space.set("b", "b2");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.a", "a2", 2)});

  // A change of A queued before the re-point is still delivered; none after.
  space.set("a", "a3");
  space.setMeta("m", TupleRef{kSelf, "b"});
  CHECK(str(space.indirectTarget(id)) == "7.b");
  space.set("a", "a4");
  space.set("b", "b3");
  space.set("a", "a5");
  space.set("b", "b4");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.a", "a3", 3), changed("7.b", "b2", 2),
                                        changed("7.b", "b3", 3), changed("7.b", "b4", 4)});

  space.set("a", "a6");
  space.set("b", "b5");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.b", "b5", 5)});

  // Re-pointed during a dispatch, from inside a callback.
  space.addCallback(Pattern("trigger"), peis::kOnChange, [&](EventKind, const Tuple&) {
    space.setMeta("m", TupleRef{kSelf, "a"});
    space.set("b", "b6");
    space.set("a", "a7");
  });
  space.set("trigger", "go");
  space.set("b", "b-before");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.b", "b-before", 6), changed("7.a", "a6", 6),
                                        changed("7.a", "a7", 7)});
}

TEST_CASE("re-pointing to a target without a value waits for its first value", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.set("a", "a1");
  space.setMeta("m", TupleRef{kSelf, "a"});
  auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
  space.dispatch();
  rec.take();

  space.setMeta("m", TupleRef{kSelf, "empty"});
  space.set("a", "a2");
  space.dispatch();
  CHECK(rec.seen.empty());
  CHECK(str(space.indirectTarget(id)) == "7.empty");

  space.set("empty", "first");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.empty", "first", 1)});

  // A remote target the cache does not hold yet.
  space.setMeta("m", TupleRef{30, "far"});
  space.dispatch();
  CHECK(rec.seen.empty());
  REQUIRE(space.accept(remoteTuple(30, "far", "hello", 9)));
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("30.far", "hello", 9)});
}

TEST_CASE("deleting the meta tuple stops an indirect callback", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.set("target", "t1");
  space.setMeta("m", TupleRef{kSelf, "target"});
  auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
  space.dispatch();
  rec.take();

  space.set("target", "t2");
  CHECK(space.erase("m"));
  space.set("target", "t3");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.target", "t2", 2)});
  CHECK(str(space.indirectTarget(id)) == "none");

  space.set("target", "t4");
  space.erase("target");
  space.dispatch();
  CHECK(rec.seen.empty());

  // Re-creating the meta tuple makes it follow again.
  space.set("target", "t6");
  space.setMeta("m", TupleRef{kSelf, "target"});
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.target", "t6", 6)});

  // Expiry of the meta tuple stops it too.
  peis::WriteOptions ttl = metaOptions();
  ttl.ttl = 1s;
  space.set("m", "7.target", ttl);
  clock.advance(1s);
  CHECK(space.expire() == 1);
  space.set("target", "t7");
  space.dispatch();
  CHECK(rec.seen.empty());
}

TEST_CASE("removeCallback stops an indirect callback", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.set("target", "t1");
  space.setMeta("m", TupleRef{kSelf, "target"});

  SECTION("after it ran") {
    auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
    space.dispatch();
    CHECK(rec.take().size() == 1);
    space.set("target", "t2");  // queued for it
    CHECK(space.removeCallback(id));
    CHECK_FALSE(space.removeCallback(id));
    CHECK(str(space.indirectTarget(id)) == "none");
    space.set("target", "t3");
    space.setMeta("m", TupleRef{kSelf, "other"});
    space.set("other", "o");
    space.dispatch();
    CHECK(rec.seen.empty());
  }

  SECTION("before its first delivery ran") {
    auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
    CHECK(space.removeCallback(id));
    space.dispatch();
    CHECK(rec.seen.empty());
  }

  SECTION("from inside its own call") {
    peis::CallbackId id = 0;
    int calls = 0;
    id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, [&](EventKind, const Tuple&) {
      ++calls;
      space.removeCallback(id);
    });
    space.set("target", "t2");
    space.set("target", "t3");
    space.dispatch();
    CHECK(calls == 1);
  }

  SECTION("from inside another callback of the same dispatch") {
    auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
    space.dispatch();
    rec.take();
    int removed = 0;
    space.addCallback(Pattern("target"), peis::kOnChange, [&](EventKind, const Tuple& t) {
      if (t.data == "t3" && space.removeCallback(id)) ++removed;
    });
    // t3 and t4 are queued for the indirect callback, but the plain callback
    // of the t3 event removes it first.
    space.set("target", "t2");
    space.set("target", "t3");
    space.set("target", "t4");
    space.dispatch();
    CHECK(removed == 1);
    CHECK(rec.take() == std::vector<Seen>{changed("7.target", "t2", 2)});
  }
}

TEST_CASE("an indirect callback follows a meta tuple of another owner", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;

  auto id = space.addIndirectCallback(20, "goal", peis::kOnAny, rec.make());
  space.dispatch();
  CHECK(rec.seen.empty());

  REQUIRE(space.accept(remoteTuple(20, "goal.a", "ga1", 4)));
  REQUIRE(space.accept(remoteMeta(20, "goal", "20.goal.a", 1)));
  CHECK(str(space.indirectTarget(id)) == "20.goal.a");
  REQUIRE(space.accept(remoteTuple(20, "goal.a", "ga2", 5)));
  space.dispatch();
  CHECK(rec.take() ==
        std::vector<Seen>{changed("20.goal.a", "ga1", 4), changed("20.goal.a", "ga2", 5)});

  // A stale copy of the target is not delivered again.
  CHECK_FALSE(space.accept(remoteTuple(20, "goal.a", "old", 3)));
  space.dispatch();
  CHECK(rec.seen.empty());

  // The owner re-points it at one of our tuples.
  space.set("local", "l1");
  REQUIRE(space.accept(remoteMeta(20, "goal", "7.local", 2)));
  REQUIRE(space.accept(remoteTuple(20, "goal.a", "ga3", 6)));
  space.set("local", "l2");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("7.local", "l1", 1), changed("7.local", "l2", 2)});

  // A stale copy of the meta tuple changes nothing.
  CHECK_FALSE(space.accept(remoteMeta(20, "goal", "20.goal.a", 1)));
  CHECK(str(space.indirectTarget(id)) == "7.local");

  // The owner deletes its meta tuple.
  REQUIRE(space.acceptDelete(20, "goal", 3));
  space.set("local", "l3");
  space.dispatch();
  CHECK(rec.seen.empty());
  CHECK(str(space.indirectTarget(id)) == "none");
}

TEST_CASE("an indirect callback follows a meta tuple naming its owner by name", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  REQUIRE(space.accept(remoteTuple(20, "kernel.name", "Astrid", 1)));
  REQUIRE(space.accept(remoteTuple(20, "pos", "p1", 1)));
  space.set("m", "Astrid.pos", metaOptions());
  auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
  CHECK(str(space.indirectTarget(id)) == "20.pos");
  REQUIRE(space.accept(remoteTuple(20, "pos", "p2", 2)));
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("20.pos", "p1", 1), changed("20.pos", "p2", 2)});
}

TEST_CASE("an indirect callback on a named owner follows once the name is known", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.set("m", "Bob.pos", metaOptions());
  auto id = space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
  space.dispatch();
  CHECK(rec.seen.empty());
  CHECK(str(space.indirectTarget(id)) == "none");

  // Bob's tuples arrive before his name: still unresolved.
  REQUIRE(space.accept(remoteTuple(21, "pos", "b1", 1)));
  space.dispatch();
  CHECK(rec.seen.empty());

  // Learning the name resolves the meta tuple, as getIndirect already does.
  REQUIRE(space.accept(remoteTuple(21, "kernel.name", "Bob", 1)));
  CHECK(space.getIndirect(kSelf, "m")->data == "b1");
  CHECK(str(space.indirectTarget(id)) == "21.pos");
  REQUIRE(space.accept(remoteTuple(21, "pos", "b2", 2)));
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("21.pos", "b1", 1), changed("21.pos", "b2", 2)});

  // Another PEIS taking the same name makes it ambiguous: unresolved again.
  REQUIRE(space.accept(remoteTuple(22, "kernel.name", "Bob", 1)));
  CHECK(str(space.indirectTarget(id)) == "none");
  REQUIRE(space.accept(remoteTuple(21, "pos", "b3", 3)));
  space.dispatch();
  CHECK(rec.seen.empty());

  // The other one renames itself: Bob is 21 again, its current value is delivered.
  REQUIRE(space.accept(remoteTuple(22, "kernel.name", "Carol", 2)));
  CHECK(str(space.indirectTarget(id)) == "21.pos");
  space.dispatch();
  CHECK(rec.take() == std::vector<Seen>{changed("21.pos", "b3", 3)});
}

TEST_CASE("indirect deliveries stay exact across a long random interleaving", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });

  // Targets: two own tuples, one that starts empty, and a remote one.
  const std::vector<TupleRef> targets{{kSelf, "a"}, {kSelf, "b"}, {kSelf, "late"}, {30, "far"}};
  std::map<TupleRef, std::uint64_t> remoteSeqno{{TupleRef{30, "far"}, 0}};
  space.set("a", "a-init");
  space.set("b", "b-init");

  auto seed = GENERATE(1u, 2u, 3u, 20240611u);
  INFO("seed " << seed);
  std::mt19937 rng(seed);

  TupleRef modelTarget = targets[0];
  space.setMeta("m", modelTarget);

  // What must arrive, built when each event happens; deliveries keep event
  // order, so when dispatch runs does not change this list.
  std::vector<Seen> expected;
  std::vector<Seen> delivered;
  auto currentOf = [&](const TupleRef& ref) { return space.get(ref.owner, ref.key); };
  if (auto now = currentOf(modelTarget)) {
    expected.push_back(changed(now->fullName(), now->data, now->seqno));
  }

  // What the callback checks while it runs: it learns of re-points from a
  // plain callback on the meta tuple, whose delivery precedes the re-point's.
  TupleRef epochTarget = modelTarget;
  std::uint64_t epochLast = 0;
  std::size_t violations = 0;
  auto id =
      space.addIndirectCallback(kSelf, "m", peis::kOnAny, [&](EventKind kind, const Tuple& t) {
        delivered.push_back(Seen{kind, t.fullName(), t.data, t.seqno});
        if (t.owner != epochTarget.owner || t.key != epochTarget.key) {
          ++violations;
          UNSCOPED_INFO("delivered " << t.fullName() << " while pointing at " << epochTarget.str());
        }
        if (t.seqno <= epochLast) {
          ++violations;
          UNSCOPED_INFO("seqno " << t.seqno << " of " << t.fullName() << " after " << epochLast);
        }
        epochLast = t.seqno;
      });
  space.addCallback(Pattern::exact(kSelf, "m"), peis::kOnChange, [&](EventKind, const Tuple& t) {
    const auto name = peis::parseFullName(t.data);
    const TupleRef now{*name.ownerId(), name.key};
    if (now != epochTarget) {
      epochTarget = now;
      epochLast = 0;
    }
  });

  std::size_t repoints = 0;
  std::size_t dispatches = 0;
  for (int step = 0; step < 1000; ++step) {
    const auto op = rng() % 100;
    const auto& ref = targets[rng() % targets.size()];
    const bool isTarget = ref == modelTarget;
    if (op < 60) {
      // Write to a target (A and B most often).
      const TupleRef& write = op < 25 ? targets[0] : op < 50 ? targets[1] : ref;
      const bool followed = write == modelTarget;
      const std::string data = write.key + "-" + std::to_string(step);
      peis::TuplePtr stored;
      if (write.owner == kSelf) {
        stored = space.set(write.key, data);
      } else {
        REQUIRE(space.accept(remoteTuple(write.owner, write.key, data, ++remoteSeqno[write])));
        stored = space.get(write.owner, write.key);
      }
      if (followed) expected.push_back(changed(stored->fullName(), data, stored->seqno));
    } else if (op < 65) {
      // Delete a target.
      const auto before = currentOf(ref);
      bool erased = false;
      if (ref.owner == kSelf) {
        erased = space.erase(ref.key);
      } else {
        erased = space.acceptDelete(ref.owner, ref.key, ++remoteSeqno[ref]);
      }
      CHECK(erased == (before != nullptr));
      if (erased && isTarget) {
        const std::uint64_t deleteSeqno =
            ref.owner == kSelf ? space.seqno(kSelf, ref.key) : remoteSeqno[ref];
        CHECK(deleteSeqno > before->seqno);
        expected.push_back(Seen{EventKind::Deleted, before->fullName(), before->data, deleteSeqno});
      }
    } else if (op < 85) {
      // Re-point (sometimes at the same target: no re-point at all).
      space.setMeta("m", ref);
      ++repoints;
      if (!isTarget) {
        modelTarget = ref;
        if (auto now = currentOf(ref)) {
          expected.push_back(changed(now->fullName(), now->data, now->seqno));
        }
      }
      CHECK(str(space.indirectTarget(id)) == modelTarget.str());
    } else {
      dispatches += space.dispatch() > 0 ? 1 : 0;
    }
  }
  space.dispatch();

  CHECK(violations == 0);
  CHECK(repoints > 100);
  CHECK(dispatches > 50);
  CHECK(expected.size() > 200);
  UNSCOPED_INFO("expected " << expected.size() << " repoints " << repoints << " dispatches "
                            << dispatches);
  REQUIRE(delivered.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    INFO("delivery " << i);
    CHECK(delivered[i] == expected[i]);
  }
}

TEST_CASE("an indirect callback never delivers a seqno twice or out of order", "[unit][meta]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;

  SECTION("the expiry of a remote target repeats its seqno and is not delivered") {
    auto far = remoteTuple(9, "x", "x4", 4);
    far.ts_expire = clock.now + 1s;
    REQUIRE(space.accept(far));
    space.setMeta("m", TupleRef{9, "x"});
    space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
    Recorder plain;
    space.addCallback(Pattern("x", 9), peis::kOnDelete, plain.make());
    space.dispatch();
    CHECK(rec.take() == std::vector<Seen>{changed("9.x", "x4", 4)});
    clock.advance(1s);
    CHECK(space.expire() == 1);
    space.dispatch();
    CHECK(plain.seen == std::vector<Seen>{{EventKind::Deleted, "9.x", "x4", 4}});
    CHECK(rec.seen.empty());
    REQUIRE(space.accept(remoteTuple(9, "x", "x5", 5)));
    space.dispatch();
    CHECK(rec.take() == std::vector<Seen>{changed("9.x", "x5", 5)});
  }

  SECTION("deliveries run out of order skip the older seqno") {
    space.set("t", "t1");
    space.setMeta("m", TupleRef{kSelf, "t"});
    space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
    space.dispatch();
    rec.take();
    space.set("t", "t2");
    space.set("t", "t3");
    auto older = space.nextDelivery();
    auto newer = space.nextDelivery();
    REQUIRE(older);
    REQUIRE(newer);
    newer->run();
    older->run();
    CHECK(rec.take() == std::vector<Seen>{changed("7.t", "t3", 3)});
  }

  SECTION("an old target's delivery run after the re-point is dropped") {
    space.set("a", "a1");
    space.set("b", "b1");
    space.setMeta("m", TupleRef{kSelf, "a"});
    space.addIndirectCallback(kSelf, "m", peis::kOnAny, rec.make());
    space.dispatch();
    rec.take();
    space.set("a", "a2");                      // matched while pointing at a
    space.setMeta("m", TupleRef{kSelf, "b"});  // queues the re-point
    auto oldTarget = space.nextDelivery();
    auto repoint = space.nextDelivery();
    REQUIRE(oldTarget);
    REQUIRE(repoint);
    CHECK_FALSE(space.nextDelivery());
    repoint->run();
    oldTarget->run();
    CHECK(rec.take() == std::vector<Seen>{changed("7.b", "b1", 1)});
  }
}
