// Unit tests of TupleSpace: stamping, reads, expiry, append, limits, the
// cache of other owners' tuples, names, callbacks and kernel.all-keys. The
// clock is a ManualClock, so nothing here sleeps.
#include "tuple_space.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdint>
#include <memory>
#include <ostream>
#include <stdexcept>
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

using namespace std::chrono_literals;
using peis::Error;
using peis::ErrorCode;
using peis::EventKind;
using peis::Pattern;
using peis::Timestamp;
using peis::Tuple;
using peis::TuplePtr;
using peis::TupleSpace;
using peis::test::ManualClock;

namespace {

constexpr peis::PeisId kSelf = 7;

using peis::test::HasCode;

using peis::test::remoteTuple;

// One delivered event, flattened for comparison.
struct Seen {
  std::string tag;
  EventKind kind;
  std::string name;  // OWNER.KEY
  std::string data;
  std::uint64_t seqno;
  bool operator==(const Seen&) const = default;
};

std::ostream& operator<<(std::ostream& os, const Seen& seen) {
  return os << "{" << seen.tag << " " << (seen.kind == EventKind::Changed ? "changed" : "deleted")
            << " " << seen.name << "='" << seen.data << "' #" << seen.seqno << "}";
}

// Records every delivery of the callbacks it makes, in delivery order.
struct Recorder {
  std::vector<Seen> seen;
  peis::Callback make(std::string tag) {
    return [this, tag](EventKind kind, const Tuple& tuple) {
      seen.push_back(Seen{tag, kind, tuple.fullName(), tuple.data, tuple.seqno});
    };
  }
};

std::vector<std::string> namesOf(const std::vector<peis::TuplePtr>& tuples) {
  std::vector<std::string> names;
  for (const auto& tuple : tuples) names.push_back(tuple->fullName());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

TEST_CASE("TupleSpace rejects an invalid own id", "[unit][tuplespace]") {
  ManualClock clock;
  auto now = [&] { return clock.now; };
  REQUIRE_THROWS_MATCHES(TupleSpace(0, now), Error, HasCode(ErrorCode::InvalidArgument));
  REQUIRE_THROWS_MATCHES(TupleSpace(-3, now), Error, HasCode(ErrorCode::InvalidArgument));
  TupleSpace space(kSelf, now);
  CHECK(space.self() == kSelf);
  CHECK(space.size() == 0);
}

TEST_CASE("set stamps owner, creator, ts_write and a per-key increasing seqno",
          "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  const Timestamp t0 = clock.now;

  auto first = space.set("position.x", "1.5");
  REQUIRE(first);
  CHECK(first->owner == kSelf);
  CHECK(first->creator == kSelf);
  CHECK(first->key == "position.x");
  CHECK(first->data == "1.5");
  CHECK(first->mimetype == peis::kDefaultMimetype);
  CHECK(first->encoding == peis::Encoding::Ascii);
  CHECK(first->ts_write == t0);
  CHECK(first->ts_user == peis::kNoTime);
  CHECK(first->ts_expire == peis::kNoTime);
  CHECK(first->seqno == 1);

  clock.advance(250ms);
  auto second = space.set("position.x", "2.5");
  CHECK(second->seqno == 2);
  CHECK(second->ts_write == t0 + 250ms);
  CHECK(second->data == "2.5");
  // The earlier value handed out is an immutable snapshot.
  CHECK(first->data == "1.5");
  CHECK(first->seqno == 1);

  // Another key counts on its own.
  auto other = space.set("position.y", "0");
  CHECK(other->seqno == 1);

  std::uint64_t last = second->seqno;
  for (int i = 0; i < 20; ++i) {
    clock.advance(1ms);
    auto next = space.set("position.x", std::to_string(i));
    CHECK(next->seqno > last);
    CHECK(next->ts_write == clock.now);
    last = next->seqno;
  }
  CHECK(last == 22);
  CHECK(space.seqno(kSelf, "position.x") == 22);
  CHECK(space.seqno(kSelf, "position.y") == 1);

  auto got = space.get(kSelf, "position.x");
  REQUIRE(got);
  CHECK(got->data == "19");
  CHECK(got->seqno == 22);
  CHECK(space.size() == 2);
}

TEST_CASE("set honours a creator override and the write options", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });

  auto written = space.set("cmd", "go", {}, 42);
  CHECK(written->owner == kSelf);
  CHECK(written->creator == 42);
  CHECK(space.get(kSelf, "cmd")->creator == 42);

  auto mine = space.set("cmd", "stop");
  CHECK(mine->creator == kSelf);

  peis::WriteOptions options;
  options.mimetype = "image/png";
  options.encoding = peis::Encoding::Binary;
  options.ts_user = clock.now - 3s;
  const std::string bytes("\x89PNG\0\x01", 6);
  auto image = space.set("camera.image", bytes, options);
  CHECK(image->mimetype == "image/png");
  CHECK(image->encoding == peis::Encoding::Binary);
  CHECK(image->ts_user == clock.now - 3s);
  CHECK(image->ts_write == clock.now);
  CHECK(image->data == bytes);
  CHECK(image->data.size() == 6);

  // Options do not stick to the key: the next plain write is plain again.
  auto plain = space.set("camera.image", "none");
  CHECK(plain->mimetype == peis::kDefaultMimetype);
  CHECK(plain->encoding == peis::Encoding::Ascii);
  CHECK(plain->ts_user == peis::kNoTime);
}

TEST_CASE("get of an absent tuple is null", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  CHECK(space.get(kSelf, "nothing") == nullptr);
  space.set("a", "1");
  CHECK(space.get(kSelf, "a") != nullptr);
  CHECK(space.get(kSelf, "a.b") == nullptr);
  CHECK(space.get(8, "a") == nullptr);
  CHECK(space.seqno(8, "a") == 0);
  CHECK(space.seqno(kSelf, "nothing") == 0);
}

TEST_CASE("find matches patterns with owner filters and wildcards", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  space.set("a.x", "1");
  space.set("a.y", "2");
  space.set("a.y.z", "3");
  space.set("b", "4");
  REQUIRE(space.accept(remoteTuple(9, "a.x", "r1", 1)));
  REQUIRE(space.accept(remoteTuple(9, "c", "r2", 1)));

  using V = std::vector<std::string>;
  CHECK(namesOf(space.find(Pattern("a.*", kSelf))) == V{"7.a.x", "7.a.y"});
  CHECK(namesOf(space.find(Pattern("a.**", kSelf))) == V{"7.a.x", "7.a.y", "7.a.y.z"});
  CHECK(namesOf(space.find(Pattern("a.**", 9))) == V{"9.a.x"});
  CHECK(namesOf(space.find(Pattern("a.x"))) == V{"7.a.x", "9.a.x"});
  CHECK(namesOf(space.find(Pattern("*.x"))) == V{"7.a.x", "9.a.x"});
  CHECK(namesOf(space.find(Pattern("*"))) == V{"7.b", "9.c"});
  CHECK(namesOf(space.find(Pattern("*", kSelf))) == V{"7.b"});
  CHECK(namesOf(space.find(Pattern())) == V{"7.a.x", "7.a.y", "7.a.y.z", "7.b", "9.a.x", "9.c"});
  CHECK(namesOf(space.find(Pattern("**", 9))) == V{"9.a.x", "9.c"});
  CHECK(space.find(Pattern("**", 8)).empty());
  CHECK(space.find(Pattern("a")).empty());  // "a" itself holds no value
  CHECK(namesOf(space.find(Pattern::parse("*.a.*"))) == V{"7.a.x", "7.a.y", "9.a.x"});
  CHECK(namesOf(space.find(Pattern().data("2"))) == V{"7.a.y"});

  auto found = space.find(Pattern::exact(9, "a.x"));
  REQUIRE(found.size() == 1);
  CHECK(found.front()->data == "r1");
}

TEST_CASE("erase deletes an own tuple, queues a delete event and keeps the seqno",
          "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.addCallback(Pattern("**", kSelf), peis::kOnAny, rec.make("cb"));

  CHECK_FALSE(space.erase("x"));
  CHECK_FALSE(space.hasPendingDeliveries());

  space.set("x", "one");
  space.set("x", "two");
  clock.advance(1s);
  CHECK(space.erase("x"));
  CHECK(space.get(kSelf, "x") == nullptr);
  CHECK(space.size() == 0);
  CHECK(space.keysOf(kSelf).empty());
  const auto afterDelete = space.seqno(kSelf, "x");
  CHECK(afterDelete == 3);
  CHECK_FALSE(space.erase("x"));
  CHECK(space.seqno(kSelf, "x") == afterDelete);

  CHECK(space.dispatch() == 3);
  REQUIRE(rec.seen.size() == 3);
  CHECK(rec.seen[2] == Seen{"cb", EventKind::Deleted, "7.x", "two", 3});

  auto again = space.set("x", "three");
  CHECK(again->seqno > afterDelete);
  CHECK(again->seqno == 4);

  REQUIRE_THROWS_MATCHES(space.erase("a..b"), Error, HasCode(ErrorCode::InvalidKey));
}

TEST_CASE("the delete event of erase carries the deletion time", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  std::vector<Tuple> deleted;
  space.addCallback(Pattern(), peis::kOnDelete,
                    [&](EventKind, const Tuple& tuple) { deleted.push_back(tuple); });
  space.set("k", "v");
  clock.advance(5s);
  space.erase("k");
  space.dispatch();
  REQUIRE(deleted.size() == 1);
  CHECK(deleted[0].ts_write == clock.now);
  CHECK(deleted[0].owner == kSelf);
  CHECK(deleted[0].key == "k");
}

TEST_CASE("tuples expire by ttl and by absolute ts_expire on the injected clock",
          "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  const Timestamp t0 = clock.now;
  Recorder rec;
  space.addCallback(Pattern(), peis::kOnDelete, rec.make("del"));

  CHECK(space.nextExpiry() == peis::kNoTime);
  CHECK(space.expire() == 0);

  peis::WriteOptions ttl;
  ttl.ttl = 5s;
  auto relative = space.set("relative", "r", ttl);
  CHECK(relative->ts_expire == t0 + 5s);

  peis::WriteOptions both;
  both.ts_expire = t0 + 2s;
  both.ttl = 10s;  // the absolute expiry wins
  auto absolute = space.set("absolute", "a", both);
  CHECK(absolute->ts_expire == t0 + 2s);

  space.set("forever", "f");
  CHECK(space.nextExpiry() == t0 + 2s);

  // Still visible one microsecond before its expiry.
  clock.now = t0 + 2s - 1us;
  CHECK(space.get(kSelf, "absolute") != nullptr);
  CHECK(space.expire() == 0);

  // At its expiry time get() and find() hide it before expire() runs.
  clock.now = t0 + 2s;
  CHECK(space.get(kSelf, "absolute") == nullptr);
  CHECK(namesOf(space.find(Pattern())) == std::vector<std::string>{"7.forever", "7.relative"});
  CHECK(space.size() == 3);
  CHECK(space.dispatch() == 0);  // no delete event before expire()

  CHECK(space.expire() == 1);
  CHECK(space.size() == 2);
  CHECK(space.nextExpiry() == t0 + 5s);
  CHECK(space.dispatch() == 1);
  REQUIRE(rec.seen.size() == 1);
  CHECK(rec.seen[0].kind == EventKind::Deleted);
  CHECK(rec.seen[0].name == "7.absolute");
  CHECK(rec.seen[0].seqno == 2);  // the deletion consumed a seqno
  CHECK(space.seqno(kSelf, "absolute") == 2);

  clock.now = t0 + 60s;
  CHECK(space.get(kSelf, "relative") == nullptr);
  CHECK(space.expire() == 1);
  CHECK(space.expire() == 0);
  CHECK(space.nextExpiry() == peis::kNoTime);
  CHECK(space.get(kSelf, "forever") != nullptr);
  space.dispatch();
  REQUIRE(rec.seen.size() == 2);
  CHECK(rec.seen[1].name == "7.relative");

  // A re-created expired key continues its seqno.
  CHECK(space.set("absolute", "again")->seqno == 3);
}

TEST_CASE("expire removes several tuples, remote ones included", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  const Timestamp t0 = clock.now;
  Recorder rec;
  space.addCallback(Pattern(), peis::kOnDelete, rec.make("del"));

  auto remote = remoteTuple(9, "sensor", "17", 4);
  remote.ts_expire = t0 + 3s;
  REQUIRE(space.accept(remote));
  peis::WriteOptions ttl;
  ttl.ttl = 1s;
  space.set("a", "1", ttl);
  space.set("b", "2", ttl);
  CHECK(space.nextExpiry() == t0 + 1s);

  clock.advance(10s);
  CHECK(space.get(9, "sensor") == nullptr);
  CHECK(space.expire() == 3);
  CHECK(space.size() == 0);
  CHECK(space.dispatch() == 3);
  std::vector<std::string> names;
  for (const auto& seen : rec.seen) names.push_back(seen.name);
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"7.a", "7.b", "9.sensor"});
  for (const auto& seen : rec.seen) {
    if (seen.name == "9.sensor") CHECK(seen.seqno == 4);  // the owner's seqno
  }
}

TEST_CASE("append creates, concatenates and checks ifSeqno", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.addCallback(Pattern("log"), peis::kOnAny, rec.make("log"));

  auto created = space.append("log", "ab");
  CHECK(created->data == "ab");
  CHECK(created->seqno == 1);

  auto joined = space.append("log", "cd");
  CHECK(joined->data == "abcd");
  CHECK(joined->seqno == 2);

  auto conditional = space.append("log", "ef", 2);
  CHECK(conditional->data == "abcdef");
  CHECK(conditional->seqno == 3);
  CHECK(space.dispatch() == 3);

  REQUIRE_THROWS_MATCHES(space.append("log", "XX", 2), Error, HasCode(ErrorCode::Conflict));
  REQUIRE_THROWS_MATCHES(space.append("log", "XX", 0), Error, HasCode(ErrorCode::Conflict));
  CHECK(space.get(kSelf, "log")->data == "abcdef");
  CHECK(space.seqno(kSelf, "log") == 3);
  CHECK_FALSE(space.hasPendingDeliveries());
  CHECK(space.dispatch() == 0);

  // ifSeqno 0 means "still absent".
  auto fresh = space.append("fresh", "x", 0);
  CHECK(fresh->data == "x");
  REQUIRE_THROWS_MATCHES(space.append("other", "x", 1), Error, HasCode(ErrorCode::Conflict));
  CHECK(space.get(kSelf, "other") == nullptr);

  REQUIRE_THROWS_MATCHES(space.append("a*b", "x"), Error, HasCode(ErrorCode::InvalidKey));
}

TEST_CASE("append keeps the mimetype and encoding of the current value", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  peis::WriteOptions binary;
  binary.mimetype = "application/octet-stream";
  binary.encoding = peis::Encoding::Binary;
  space.set("blob", "12", binary, 3);
  auto appended = space.append("blob", "34");
  CHECK(appended->data == "1234");
  CHECK(appended->mimetype == "application/octet-stream");
  CHECK(appended->encoding == peis::Encoding::Binary);
  CHECK(appended->creator == kSelf);
  CHECK(space.append("blob", "5", std::nullopt, {}, 12)->creator == 12);

  peis::WriteOptions json;
  json.mimetype = "application/json";
  auto created = space.append("doc", "{}", std::nullopt, json);
  CHECK(created->mimetype == "application/json");
}

TEST_CASE("append respects the data limit", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(
      kSelf, [&] { return clock.now; }, peis::SpaceLimits{16});

  REQUIRE_THROWS_MATCHES(space.append("log", std::string(17, 'x')), Error,
                         HasCode(ErrorCode::TooLarge));
  CHECK(space.get(kSelf, "log") == nullptr);

  space.append("log", std::string(10, 'a'));
  REQUIRE_THROWS_MATCHES(space.append("log", std::string(7, 'b')), Error,
                         HasCode(ErrorCode::TooLarge));
  CHECK(space.get(kSelf, "log")->data == std::string(10, 'a'));
  CHECK(space.seqno(kSelf, "log") == 1);

  auto full = space.append("log", std::string(6, 'c'));
  CHECK(full->data.size() == 16);
  CHECK(full->seqno == 2);
  REQUIRE_THROWS_MATCHES(space.append("log", "d"), Error, HasCode(ErrorCode::TooLarge));
  CHECK(space.get(kSelf, "log")->data.size() == 16);
  CHECK(space.append("log", "")->data.size() == 16);
}

TEST_CASE("setDefault writes only when the key has no value", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });

  auto first = space.setDefault("mode", "auto");
  CHECK(first->data == "auto");
  CHECK(first->seqno == 1);

  auto second = space.setDefault("mode", "manual");
  CHECK(second->data == "auto");
  CHECK(second->seqno == 1);
  CHECK(space.get(kSelf, "mode")->data == "auto");
  CHECK(space.seqno(kSelf, "mode") == 1);

  space.set("mode", "manual");
  CHECK(space.setDefault("mode", "auto")->data == "manual");

  space.erase("mode");
  auto recreated = space.setDefault("mode", "auto");
  CHECK(recreated->data == "auto");
  CHECK(recreated->seqno == 4);
}

TEST_CASE("writes over the data limit are refused and store nothing", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(
      kSelf, [&] { return clock.now; }, peis::SpaceLimits{16});
  CHECK(space.limits().maxDataBytes == 16);
  Recorder rec;
  space.addCallback(Pattern(), peis::kOnAny, rec.make("any"));

  REQUIRE_THROWS_MATCHES(space.set("big", std::string(17, 'x')), Error,
                         HasCode(ErrorCode::TooLarge));
  CHECK(space.get(kSelf, "big") == nullptr);
  CHECK(space.size() == 0);
  CHECK(space.seqno(kSelf, "big") == 0);
  CHECK(space.dispatch() == 0);

  CHECK(space.set("big", std::string(16, 'x'))->seqno == 1);
  REQUIRE_THROWS_MATCHES(space.set("big", std::string(17, 'y')), Error,
                         HasCode(ErrorCode::TooLarge));
  CHECK(space.get(kSelf, "big")->data == std::string(16, 'x'));
  CHECK(space.seqno(kSelf, "big") == 1);

  REQUIRE_THROWS_MATCHES(space.setDefault("other", std::string(17, 'x')), Error,
                         HasCode(ErrorCode::TooLarge));
  REQUIRE_THROWS_MATCHES(space.accept(remoteTuple(9, "r", std::string(17, 'x'), 1)), Error,
                         HasCode(ErrorCode::TooLarge));
  CHECK(space.get(9, "r") == nullptr);
  CHECK(space.size() == 1);
}

TEST_CASE("a data limit above the hard maximum is clamped", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(
      kSelf, [&] { return clock.now; }, peis::SpaceLimits{peis::kMaxDataBytes + 5});
  CHECK(space.limits().maxDataBytes == peis::kMaxDataBytes);
  TupleSpace defaults(kSelf, [&] { return clock.now; });
  CHECK(defaults.limits().maxDataBytes == peis::kDefaultMaxDataBytes);
}

TEST_CASE("invalid keys are refused with InvalidKey", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });

  std::string manyParts = "p";
  for (int i = 1; i < 33; ++i) manyParts += ".p";
  REQUIRE(peis::splitKey(manyParts).size() == 33);
  const std::string longKey(257, 'k');

  for (const std::string& key : {longKey, manyParts, std::string("a..b"), std::string("a*b"),
                                 std::string(""), std::string(".a"), std::string("a.")}) {
    INFO("key '" << key << "'");
    REQUIRE_THROWS_MATCHES(space.set(key, "v"), Error, HasCode(ErrorCode::InvalidKey));
    REQUIRE_THROWS_MATCHES(space.append(key, "v"), Error, HasCode(ErrorCode::InvalidKey));
    REQUIRE_THROWS_MATCHES(space.setDefault(key, "v"), Error, HasCode(ErrorCode::InvalidKey));
    REQUIRE_THROWS_MATCHES(space.erase(key), Error, HasCode(ErrorCode::InvalidKey));
    CHECK(space.seqno(kSelf, key) == 0);
  }
  CHECK(space.size() == 0);
  CHECK_FALSE(space.hasPendingDeliveries());

  // The limits themselves are allowed.
  CHECK(space.set(std::string(256, 'k'), "v"));
  std::string thirtyTwo = "p";
  for (int i = 1; i < 32; ++i) thirtyTwo += ".p";
  CHECK(space.set(thirtyTwo, "v"));
  CHECK(space.size() == 2);
}

TEST_CASE("an oversized mimetype is refused with InvalidArgument", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  peis::WriteOptions options;
  options.mimetype = std::string(peis::kMaxMimetypeBytes + 1, 'm');
  REQUIRE_THROWS_MATCHES(space.set("k", "v", options), Error, HasCode(ErrorCode::InvalidArgument));
  REQUIRE_THROWS_MATCHES(space.append("k", "v", std::nullopt, options), Error,
                         HasCode(ErrorCode::InvalidArgument));
  CHECK(space.get(kSelf, "k") == nullptr);
  CHECK(space.seqno(kSelf, "k") == 0);

  options.mimetype = std::string(peis::kMaxMimetypeBytes, 'm');
  CHECK(space.set("k", "v", options)->mimetype.size() == peis::kMaxMimetypeBytes);
}

TEST_CASE("accept caches newer tuples of other owners only", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.addCallback(Pattern("**", 9), peis::kOnAny, rec.make("r"));

  auto v5 = remoteTuple(9, "pos", "five", 5);
  v5.creator = 3;
  v5.mimetype = "text/x-pos";
  v5.ts_user = clock.now - 1s;
  CHECK(space.accept(v5));
  auto got = space.get(9, "pos");
  REQUIRE(got);
  CHECK(*got == v5);  // stored exactly as the owner stamped it
  CHECK(space.seqno(9, "pos") == 5);

  CHECK_FALSE(space.accept(remoteTuple(9, "pos", "five again", 5)));
  CHECK_FALSE(space.accept(remoteTuple(9, "pos", "four", 4)));
  CHECK(space.get(9, "pos")->data == "five");

  CHECK(space.accept(remoteTuple(9, "pos", "six", 6)));
  CHECK(space.get(9, "pos")->data == "six");
  CHECK(space.seqno(9, "pos") == 6);

  // Own tuples only come from set(); invalid owners and keys are refused.
  CHECK_FALSE(space.accept(remoteTuple(kSelf, "pos", "mine", 100)));
  CHECK(space.get(kSelf, "pos") == nullptr);
  CHECK_FALSE(space.accept(remoteTuple(0, "pos", "x", 1)));
  CHECK_FALSE(space.accept(remoteTuple(9, "a..b", "x", 1)));
  CHECK_FALSE(space.accept(remoteTuple(9, "a*b", "x", 1)));
  CHECK_FALSE(space.accept(remoteTuple(9, "", "x", 1)));
  CHECK(space.size() == 1);

  CHECK(space.dispatch() == 2);
  REQUIRE(rec.seen.size() == 2);
  CHECK(rec.seen[0] == Seen{"r", EventKind::Changed, "9.pos", "five", 5});
  CHECK(rec.seen[1] == Seen{"r", EventKind::Changed, "9.pos", "six", 6});
}

TEST_CASE("acceptDelete removes a cached tuple deleted at a newer seqno", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.addCallback(Pattern(), peis::kOnDelete, rec.make("del"));

  REQUIRE(space.accept(remoteTuple(9, "pos", "five", 5)));
  CHECK_FALSE(space.acceptDelete(9, "pos", 5));
  CHECK_FALSE(space.acceptDelete(9, "pos", 4));
  CHECK(space.get(9, "pos") != nullptr);
  CHECK_FALSE(space.acceptDelete(9, "absent", 10));
  CHECK_FALSE(space.acceptDelete(8, "pos", 10));

  CHECK(space.acceptDelete(9, "pos", 6));
  CHECK(space.get(9, "pos") == nullptr);
  CHECK(space.size() == 0);
  CHECK_FALSE(space.acceptDelete(9, "pos", 7));

  space.set("mine", "x");
  CHECK_FALSE(space.acceptDelete(kSelf, "mine", 100));
  CHECK(space.get(kSelf, "mine") != nullptr);

  CHECK(space.dispatch() == 1);
  REQUIRE(rec.seen.size() == 1);
  CHECK(rec.seen[0] == Seen{"del", EventKind::Deleted, "9.pos", "five", 6});

  // The owner re-creating the key later is accepted again.
  CHECK(space.accept(remoteTuple(9, "pos", "eight", 8)));
  CHECK(space.get(9, "pos")->data == "eight");
}

TEST_CASE("keysOf lists the keys of one owner in order", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  using V = std::vector<std::string>;
  CHECK(space.keysOf(kSelf).empty());
  space.set("zeta", "1");
  space.set("alpha.beta", "2");
  space.set("alpha", "3");
  REQUIRE(space.accept(remoteTuple(9, "remote", "r", 1)));
  REQUIRE(space.accept(remoteTuple(6, "before", "r", 1)));
  CHECK(space.keysOf(kSelf) == V{"alpha", "alpha.beta", "zeta"});
  CHECK(space.keysOf(9) == V{"remote"});
  CHECK(space.keysOf(6) == V{"before"});
  CHECK(space.keysOf(8).empty());
  space.erase("alpha");
  CHECK(space.keysOf(kSelf) == V{"alpha.beta", "zeta"});
}

TEST_CASE("peisNamed and resolveOwner use cached kernel.name tuples", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });

  CHECK(space.resolveOwner("12") == 12);
  CHECK(space.resolveOwner("7") == kSelf);
  CHECK(space.peisNamed("Rover").empty());
  REQUIRE_THROWS_MATCHES(space.resolveOwner("Rover"), Error, HasCode(ErrorCode::NotFound));
  REQUIRE_THROWS_MATCHES(space.resolveOwner("no.dots"), Error, HasCode(ErrorCode::InvalidName));
  REQUIRE_THROWS_MATCHES(space.resolveOwner(""), Error, HasCode(ErrorCode::InvalidName));

  REQUIRE(space.accept(remoteTuple(11, "kernel.name", "Rover", 1)));
  REQUIRE(space.accept(remoteTuple(14, "kernel.name", "Astrid", 1)));
  CHECK(space.peisNamed("Rover") == std::vector<peis::PeisId>{11});
  CHECK(space.resolveOwner("Rover") == 11);
  CHECK(space.resolveOwner("Astrid") == 14);
  CHECK(space.peisNamed("rover").empty());  // case-sensitive
  REQUIRE_THROWS_MATCHES(space.resolveOwner("Nobody"), Error, HasCode(ErrorCode::NotFound));

  // Only kernel.name counts, not other tuples with the same data.
  REQUIRE(space.accept(remoteTuple(15, "kernel.alias", "Rover", 1)));
  CHECK(space.resolveOwner("Rover") == 11);

  // The own name counts too.
  space.set("kernel.name", "Home");
  CHECK(space.resolveOwner("Home") == kSelf);

  REQUIRE(space.accept(remoteTuple(12, "kernel.name", "Rover", 3)));
  CHECK(space.peisNamed("Rover") == std::vector<peis::PeisId>{11, 12});
  try {
    space.resolveOwner("Rover");
    FAIL("an ambiguous name resolved");
  } catch (const Error& error) {
    CHECK(error.code() == ErrorCode::AmbiguousName);
    const std::string message = error.what();
    CHECK_THAT(message, Catch::Contains("11") && Catch::Contains("12") && Catch::Contains("Rover"));
  }

  // A renamed PEIS no longer carries the old name.
  REQUIRE(space.accept(remoteTuple(12, "kernel.name", "Robin", 4)));
  CHECK(space.resolveOwner("Rover") == 11);
  CHECK(space.resolveOwner("Robin") == 12);

  // An expired name tuple is no name.
  auto expiring = remoteTuple(16, "kernel.name", "Ghost", 1);
  expiring.ts_expire = clock.now + 1s;
  REQUIRE(space.accept(expiring));
  CHECK(space.resolveOwner("Ghost") == 16);
  clock.advance(1s);
  CHECK(space.peisNamed("Ghost").empty());
  REQUIRE_THROWS_MATCHES(space.resolveOwner("Ghost"), Error, HasCode(ErrorCode::NotFound));
}

TEST_CASE("callbacks are filtered by pattern and mask", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.addCallback(Pattern("a.**"), peis::kOnChange, rec.make("change"));
  space.addCallback(Pattern("a.**"), peis::kOnDelete, rec.make("delete"));
  space.addCallback(Pattern("**", kSelf), peis::kOnAny, rec.make("both"));
  space.addCallback(Pattern("a.x", 9), peis::kOnAny, rec.make("remote"));

  space.set("a.x", "1");
  space.set("b", "2");
  space.erase("a.x");
  space.erase("b");
  REQUIRE(space.accept(remoteTuple(9, "a.x", "r", 1)));
  REQUIRE(space.acceptDelete(9, "a.x", 2));
  CHECK(space.dispatch() == 6);

  const std::vector<Seen> expected{
      {"change", EventKind::Changed, "7.a.x", "1", 1},
      {"both", EventKind::Changed, "7.a.x", "1", 1},
      {"both", EventKind::Changed, "7.b", "2", 1},
      {"delete", EventKind::Deleted, "7.a.x", "1", 2},
      {"both", EventKind::Deleted, "7.a.x", "1", 2},
      {"both", EventKind::Deleted, "7.b", "2", 2},
      {"change", EventKind::Changed, "9.a.x", "r", 1},
      {"remote", EventKind::Changed, "9.a.x", "r", 1},
      {"delete", EventKind::Deleted, "9.a.x", "r", 2},
      {"remote", EventKind::Deleted, "9.a.x", "r", 2},
  };
  CHECK(rec.seen == expected);
}

TEST_CASE("an event no callback matches queues nothing", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.addCallback(Pattern("watched"), peis::kOnDelete, rec.make("w"));
  space.set("other", "1");
  space.set("watched", "1");  // matches the pattern, not the mask
  CHECK_FALSE(space.hasPendingDeliveries());
  CHECK(space.dispatch() == 0);
  space.erase("watched");
  CHECK(space.hasPendingDeliveries());
  CHECK(space.dispatch() == 1);
  CHECK(rec.seen.size() == 1);
}

TEST_CASE("dispatch runs queued deliveries in event order", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  std::vector<std::string> order;
  space.addCallback(Pattern(), peis::kOnAny,
                    [&](EventKind, const Tuple& t) { order.push_back("A:" + t.data); });
  space.addCallback(Pattern(), peis::kOnAny,
                    [&](EventKind, const Tuple& t) { order.push_back("B:" + t.data); });

  space.set("k1", "1");
  space.set("k2", "2");
  space.set("k1", "3");
  CHECK(order.empty());  // nothing runs before dispatch
  CHECK(space.hasPendingDeliveries());
  CHECK(space.dispatch() == 3);
  CHECK(order == std::vector<std::string>{"A:1", "B:1", "A:2", "B:2", "A:3", "B:3"});
  CHECK_FALSE(space.hasPendingDeliveries());
  CHECK(space.dispatch() == 0);

  // nextDelivery hands out the same deliveries one at a time.
  order.clear();
  space.set("k2", "4");
  space.erase("k1");
  auto first = space.nextDelivery();
  REQUIRE(first);
  CHECK(first->kind() == EventKind::Changed);
  CHECK(first->tuple()->data == "4");
  auto second = space.nextDelivery();
  REQUIRE(second);
  CHECK(second->kind() == EventKind::Deleted);
  CHECK(second->tuple()->key == "k1");
  CHECK_FALSE(space.nextDelivery());
  CHECK(order.empty());
  second->run();
  first->run();
  CHECK(order == std::vector<std::string>{"A:3", "B:3", "A:4", "B:4"});
}

TEST_CASE("removeCallback stops a callback, even during a dispatch", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;

  SECTION("removed before its queued event is dispatched") {
    auto id = space.addCallback(Pattern(), peis::kOnAny, rec.make("gone"));
    auto keep = space.addCallback(Pattern(), peis::kOnAny, rec.make("keep"));
    space.set("k", "1");
    CHECK(space.removeCallback(id));
    CHECK_FALSE(space.removeCallback(id));
    CHECK(space.dispatch() == 1);
    CHECK(rec.seen == std::vector<Seen>{{"keep", EventKind::Changed, "7.k", "1", 1}});
    space.set("k", "2");
    space.dispatch();
    CHECK(rec.seen.size() == 2);
    CHECK(space.removeCallback(keep));
    space.set("k", "3");
    CHECK_FALSE(space.hasPendingDeliveries());
    CHECK(space.dispatch() == 0);
    CHECK(rec.seen.size() == 2);
  }

  SECTION("removed by another callback of the same event") {
    peis::CallbackId victim = 0;
    int removals = 0;
    space.addCallback(Pattern(), peis::kOnAny, [&](EventKind, const Tuple& t) {
      rec.seen.push_back(Seen{"killer", EventKind::Changed, t.fullName(), t.data, t.seqno});
      if (space.removeCallback(victim)) ++removals;
    });
    victim = space.addCallback(Pattern(), peis::kOnAny, rec.make("victim"));
    space.set("a", "1");
    space.set("b", "2");  // queued too, matched the victim as well
    CHECK(space.dispatch() == 2);
    REQUIRE(rec.seen.size() == 2);
    CHECK(rec.seen[0].tag == "killer");
    CHECK(rec.seen[1].tag == "killer");
    CHECK(removals == 1);
  }

  SECTION("removed by a callback of an earlier event in the same dispatch") {
    peis::CallbackId victim = 0;
    space.addCallback(Pattern("first"), peis::kOnAny,
                      [&](EventKind, const Tuple&) { space.removeCallback(victim); });
    victim = space.addCallback(Pattern("second"), peis::kOnAny, rec.make("victim"));
    space.set("first", "1");
    space.set("second", "2");
    CHECK(space.dispatch() == 2);
    CHECK(rec.seen.empty());
  }

  SECTION("a callback removing itself") {
    peis::CallbackId self = 0;
    int runs = 0;
    self = space.addCallback(Pattern(), peis::kOnAny, [&](EventKind, const Tuple&) {
      ++runs;
      space.removeCallback(self);
    });
    space.set("a", "1");
    space.set("a", "2");
    space.dispatch();
    CHECK(runs == 1);
  }

  CHECK_FALSE(space.removeCallback(9999));
}

TEST_CASE("a removed callback is kept until the deliveries taken before ran",
          "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  // Its function owns `alive`: the count says whether the function exists.
  auto alive = std::make_shared<int>(0);
  std::vector<std::string> seen;
  const auto id = space.addValueCallback(
      Pattern(), peis::kOnChange, [&seen, alive](const Tuple& t) { seen.push_back(t.data); });
  space.set("k", "1");
  std::vector<TupleSpace::Delivery> taken;
  space.takeAllDeliveries(taken);
  REQUIRE(taken.size() == 1);
  space.set("k", "2");  // queued, not taken yet
  CHECK(space.removeCallback(id));
  CHECK(alive.use_count() == 2);  // a delivery taken may still point to it
  TupleSpace::RemovedCallbacks letGo;
  space.deliveriesRan(letGo);  // the queued one was not taken yet
  CHECK(letGo.empty());
  CHECK(alive.use_count() == 2);
  for (const auto& delivery : taken) delivery.run();
  CHECK(seen.empty());  // removed before its delivery ran
  taken.clear();
  space.takeAllDeliveries(taken);
  for (const auto& delivery : taken) delivery.run();
  taken.clear();
  space.deliveriesRan(letGo);
  CHECK(letGo.size() == 1);  // handed to the caller, to destroy without the lock
  letGo.clear();
  CHECK(alive.use_count() == 1);  // let go
  CHECK(seen.empty());
}

TEST_CASE("a callback removed with no delivery queued or running goes at once",
          "[unit][tuplespace]") {
  // No drain may ever come (nothing else happens in the space): a removed
  // callback must not wait for one to be let go.
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  auto alive = std::make_shared<int>(0);
  std::vector<TupleSpace::Delivery> taken;
  TupleSpace::RemovedCallbacks letGo;
  for (int i = 0; i < 3; ++i) {
    const auto id =
        space.addValueCallback(Pattern("never"), peis::kOnChange, [alive](const Tuple&) {});
    CHECK(alive.use_count() == 2);
    CHECK(space.removeCallback(id));
    CHECK(alive.use_count() == 1);
  }
  // Once deliveries were taken and ran, the same holds.
  const auto id = space.addValueCallback(Pattern(), peis::kOnChange, [alive](const Tuple&) {});
  space.set("k", "1");
  space.takeAllDeliveries(taken);
  CHECK(space.removeCallback(id));  // its delivery is taken, not run: kept
  CHECK(alive.use_count() == 2);
  for (const auto& delivery : taken) delivery.run();
  taken.clear();
  space.deliveriesRan(letGo);
  letGo.clear();
  CHECK(alive.use_count() == 1);
  const auto again = space.addValueCallback(Pattern(), peis::kOnChange, [alive](const Tuple&) {});
  CHECK(space.removeCallback(again));
  CHECK(alive.use_count() == 1);
}

TEST_CASE("a stream's deliveries keep their values however they leave the space",
          "[unit][tuplespace]") {
  // A queued delivery of a value just stored holds no reference of its
  // own until the value is replaced or removed, or the delivery is taken.
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  std::vector<std::string> seen;
  space.addValueCallback(Pattern(), peis::kOnChange | peis::kOnDelete,
                         [&](const Tuple& t) { seen.push_back(t.fullName() + "=" + t.data); });
  std::vector<TupleSpace::Delivery> taken;
  std::vector<peis::TuplePtr> spent;
  const auto runTaken = [&] {
    space.takeAllDeliveries(taken);
    for (auto& delivery : taken) {
      delivery.run();
      spent.push_back(delivery.takeTuple());
    }
    taken.clear();
    space.recycle(spent);  // reused for the next values stored
    TupleSpace::RemovedCallbacks letGo;
    space.deliveriesRan(letGo);
  };
  std::uint64_t seqno = 0;
  for (int round = 0; round < 3; ++round) {
    for (int i = 0; i < 5; ++i) {
      const auto data = std::to_string(round) + "." + std::to_string(i);
      REQUIRE(space.accept(remoteTuple(9, "s", data, ++seqno)));
      if (i == 2) REQUIRE(space.accept(remoteTuple(9, "other", data, seqno)));  // another key
    }
    runTaken();
  }
  REQUIRE(space.accept(remoteTuple(9, "s", "last", ++seqno)));
  REQUIRE(space.acceptDelete(9, "s", ++seqno));  // its delivery queued, the value removed
  REQUIRE(space.accept(remoteTuple(9, "s", "again", ++seqno)));
  REQUIRE(space.forgetOwner(9) == 2);  // "s" and "other", with a delivery queued
  runTaken();
  std::vector<std::string> expected;
  for (int round = 0; round < 3; ++round) {
    for (int i = 0; i < 5; ++i) {
      const auto data = std::to_string(round) + "." + std::to_string(i);
      expected.push_back("9.s=" + data);
      if (i == 2) expected.push_back("9.other=" + data);
    }
  }
  for (const auto* value : {"9.s=last", "9.s=last", "9.s=again", "9.other=2.2", "9.s=again"}) {
    expected.push_back(value);
  }
  CHECK(seen == expected);
}

TEST_CASE("a value callback gets every change of what it matches", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  std::vector<std::string> seen;
  space.addValueCallback(Pattern("k"), peis::kOnChange,
                         [&](const Tuple& t) { seen.push_back(t.data); });
  space.set("k", "1");
  space.set("other", "x");
  space.set("k", "2");
  CHECK(space.dispatch() == 2);
  CHECK(seen == std::vector<std::string>{"1", "2"});
  space.addValueCallbackWithHeld(Pattern("k"),
                                 [&](const Tuple& t) { seen.push_back("held " + t.data); });
  space.dispatch();
  CHECK(seen.back() == "held 2");
}

TEST_CASE("a callback may write; the nested event runs later in the same dispatch",
          "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  std::vector<std::string> order;
  std::size_t nestedDispatch = 99;

  space.addCallback(Pattern("in"), peis::kOnChange, [&](EventKind, const Tuple& t) {
    order.push_back("in:" + t.data + ":start");
    space.set("out", t.data + "!");
    nestedDispatch = space.dispatch();
    order.push_back("in:" + t.data + ":end");
  });
  space.addCallback(Pattern("out"), peis::kOnChange,
                    [&](EventKind, const Tuple& t) { order.push_back("out:" + t.data); });
  space.addCallback(Pattern("other"), peis::kOnChange,
                    [&](EventKind, const Tuple& t) { order.push_back("other:" + t.data); });

  space.set("in", "x");
  space.set("other", "y");
  CHECK(space.dispatch() == 3);
  CHECK(nestedDispatch == 0);
  CHECK(order == std::vector<std::string>{"in:x:start", "in:x:end", "other:y", "out:x!"});
  CHECK(space.get(kSelf, "out")->data == "x!");
  CHECK_FALSE(space.hasPendingDeliveries());

  // dispatch works again after the nested call returned.
  order.clear();
  space.set("out", "z");
  CHECK(space.dispatch() == 1);
  CHECK(order == std::vector<std::string>{"out:z"});
}

TEST_CASE("a dispatch interrupted by a throwing callback can be resumed", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  std::vector<std::string> order;
  space.addCallback(Pattern(), peis::kOnChange, [&](EventKind, const Tuple& t) {
    order.push_back(t.data);
    if (t.data == "boom") throw std::runtime_error("boom");
  });
  space.set("a", "1");
  space.set("a", "boom");
  space.set("a", "3");
  REQUIRE_THROWS_AS(space.dispatch(), std::runtime_error);
  CHECK(space.hasPendingDeliveries());
  CHECK(space.dispatch() == 1);
  CHECK(order == std::vector<std::string>{"1", "boom", "3"});
}

TEST_CASE("callbacks registered after an event do not see it", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder rec;
  space.addCallback(Pattern(), peis::kOnAny, rec.make("early"));
  space.set("k", "1");
  space.addCallback(Pattern(), peis::kOnAny, rec.make("late"));
  space.set("k", "2");
  CHECK(space.dispatch() == 2);
  const std::vector<Seen> expected{
      {"early", EventKind::Changed, "7.k", "1", 1},
      {"early", EventKind::Changed, "7.k", "2", 2},
      {"late", EventKind::Changed, "7.k", "2", 2},
  };
  CHECK(rec.seen == expected);
}

TEST_CASE("flushAllKeys writes the sorted own keys only when they changed", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });

  CHECK(space.allKeysDirty());
  space.flushAllKeys();
  CHECK_FALSE(space.allKeysDirty());
  auto list = space.get(kSelf, "kernel.all-keys");
  REQUIRE(list);
  CHECK(list->data == "kernel.all-keys");
  CHECK(list->seqno == 1);

  space.set("zeta", "1");
  space.set("alpha.b", "2");
  space.set("kernel.name", "Me");
  CHECK(space.allKeysDirty());
  space.flushAllKeys();
  list = space.get(kSelf, "kernel.all-keys");
  CHECK(list->data == "alpha.b kernel.all-keys kernel.name zeta");
  CHECK(list->seqno == 2);
  CHECK_FALSE(space.allKeysDirty());

  // No change of the key set: no rewrite.
  space.flushAllKeys();
  space.set("zeta", "changed value");
  CHECK_FALSE(space.allKeysDirty());
  REQUIRE(space.accept(remoteTuple(9, "remote", "r", 1)));
  CHECK_FALSE(space.allKeysDirty());
  space.flushAllKeys();
  CHECK(space.seqno(kSelf, "kernel.all-keys") == 2);

  space.erase("alpha.b");
  CHECK(space.allKeysDirty());
  space.flushAllKeys();
  CHECK(space.get(kSelf, "kernel.all-keys")->data == "kernel.all-keys kernel.name zeta");
  CHECK(space.seqno(kSelf, "kernel.all-keys") == 3);

  // Expiry of an own key changes the set too.
  peis::WriteOptions ttl;
  ttl.ttl = 1s;
  space.set("brief", "b", ttl);
  space.flushAllKeys();
  CHECK(space.get(kSelf, "kernel.all-keys")->data == "brief kernel.all-keys kernel.name zeta");
  clock.advance(2s);
  CHECK(space.expire() == 1);
  CHECK(space.allKeysDirty());
  space.flushAllKeys();
  CHECK(space.get(kSelf, "kernel.all-keys")->data == "kernel.all-keys kernel.name zeta");
  CHECK(space.seqno(kSelf, "kernel.all-keys") == 5);
}

TEST_CASE("a stream to one key, then its entry erased: nothing stale is remembered",
          "[unit][tuple-space]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  // Own key: set twice (the second set reuses the remembered entry), erase,
  // set again: a fresh entry with the next seqno.
  space.set("stream", "1");
  space.set("stream", "2");
  REQUIRE(space.erase("stream"));
  CHECK_FALSE(space.get(kSelf, "stream"));
  CHECK(space.set("stream", "4")->seqno == 4);
  CHECK(space.get(kSelf, "stream")->data == "4");
  CHECK_THROWS_MATCHES(space.set("bad..key", "x"), Error, HasCode(ErrorCode::InvalidKey));

  // Another owner's key: accepted twice, then the owner is forgotten; the
  // same key is a new entry again (a lower seqno is accepted: the owner
  // restarted).
  REQUIRE(space.accept(remoteTuple(9, "pos", "a", 5)));
  REQUIRE(space.accept(remoteTuple(9, "pos", "b", 6)));
  CHECK_FALSE(space.accept(remoteTuple(9, "pos", "old", 6)));
  CHECK(space.forgetOwner(9) == 1);
  CHECK_FALSE(space.get(9, "pos"));
  REQUIRE(space.accept(remoteTuple(9, "pos", "again", 1)));
  CHECK(space.get(9, "pos")->data == "again");

  // Expiry erases too.
  peis::WriteOptions ttl;
  ttl.ttl = 1s;
  space.set("brief", "x", ttl);
  space.set("brief", "y", ttl);
  clock.now += 2s;
  CHECK(space.expire() == 1);
  CHECK(space.set("brief", "z")->seqno == 4);
  CHECK(space.get(kSelf, "brief")->data == "z");
}

// Another owner's incarnations (issue 9): a restarted owner's seqnos start at
// 1 again and are newer than everything of its previous life.
TEST_CASE("a newer incarnation of an owner is accepted at once, an older one never",
          "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder r;
  space.addCallback(Pattern("**"), peis::kOnAny, r.make("all"));

  CHECK(space.incarnationOf(2) == 0);
  REQUIRE(space.accept(remoteTuple(2, "a", "old", 40), 100));
  REQUIRE(space.accept(remoteTuple(2, "b", "old", 7), 100));
  CHECK(space.incarnationOf(2) == 100);
  CHECK_FALSE(space.accept(remoteTuple(2, "a", "stale", 39), 100));  // same life: seqno order

  // The owner restarted: its first value is newer than the old life's 40.
  CHECK(space.accept(remoteTuple(2, "a", "new", 1), 200));
  CHECK(space.incarnationOf(2) == 200);
  CHECK(space.get(2, "a")->data == "new");
  CHECK_FALSE(space.get(2, "b"));  // gone with the old life
  // A message of the old life still in flight changes nothing.
  CHECK_FALSE(space.accept(remoteTuple(2, "b", "late", 8), 100));
  CHECK_FALSE(space.acceptDelete(2, "a", 41, 100));
  CHECK(space.get(2, "a")->data == "new");
  CHECK_FALSE(space.noteIncarnation(2, 100));
  CHECK(space.noteIncarnation(2, 0));  // 0: the one known

  space.dispatch();
  // The old life's tuples were deleted (with their own seqnos) before the new value.
  const std::vector<Seen> expected = {{"all", EventKind::Changed, "2.a", "old", 40},
                                      {"all", EventKind::Changed, "2.b", "old", 7},
                                      {"all", EventKind::Deleted, "2.a", "old", 40},
                                      {"all", EventKind::Deleted, "2.b", "old", 7},
                                      {"all", EventKind::Changed, "2.a", "new", 1}};
  CHECK(r.seen == expected);
}

TEST_CASE("an indirect callback follows its target's owner into a new life", "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  space.setMeta("mi-x", peis::TupleRef{2, "x"});
  std::vector<std::string> seen;
  space.addIndirectCallback(kSelf, "mi-x", peis::kOnChange,
                            [&](EventKind, const Tuple& t) { seen.push_back(t.data); });
  REQUIRE(space.accept(remoteTuple(2, "x", "old-9", 9), 100));
  space.dispatch();
  CHECK(seen == std::vector<std::string>{"old-9"});

  // Learnt before any value of the new life (the route announced it).
  CHECK(space.noteIncarnation(2, 200));
  REQUIRE(space.accept(remoteTuple(2, "x", "new-1", 1), 200));
  CHECK_FALSE(space.accept(remoteTuple(2, "x", "new-1 again", 1), 200));
  REQUIRE(space.accept(remoteTuple(2, "x", "new-2", 2), 200));
  space.dispatch();
  CHECK(seen == std::vector<std::string>{"old-9", "new-1", "new-2"});
}

// A value over a data limit is known by its fields, not held (issue 9).
TEST_CASE("withheld values: recorded, replaced in seqno order, forgotten with their owner",
          "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  Recorder r;
  space.addCallback(Pattern("**"), peis::kOnAny, r.make("all"));
  auto withheld = [](std::uint64_t seqno, peis::PeisId by) {
    return TupleSpace::Withheld{remoteTuple(2, "big", "", seqno), 5000, by, 1000};
  };

  REQUIRE(space.accept(remoteTuple(2, "big", "small", 3), 100));
  CHECK_FALSE(space.acceptWithheld(withheld(3, kSelf), 100));  // not newer than the value
  REQUIRE(space.acceptWithheld(withheld(4, kSelf), 100));
  CHECK_FALSE(space.get(2, "big"));  // the older value is no longer the owner's
  REQUIRE(space.withheld(2, "big"));
  CHECK(space.withheld(2, "big")->dataBytes == 5000);
  CHECK(space.withheld(2, "big")->reason(kSelf) ==
        "2.big is 5000 bytes: too large for this PEIS's --peis-max-data (1000 bytes; PEIS 7)");
  CHECK(withheld(4, 9).reason(kSelf) ==
        "2.big is 5000 bytes: too large for the --peis-max-data of PEIS 9 on the way from its "
        "owner (1000 bytes)");
  CHECK(space.findWithheld(Pattern("**", 2)).size() == 1);
  CHECK(space.findWithheld(Pattern("**", 3)).empty());
  CHECK_FALSE(space.acceptWithheld(withheld(4, kSelf), 100));
  CHECK_FALSE(space.accept(remoteTuple(2, "big", "older", 4), 100));

  // A newer value that fits replaces the record.
  REQUIRE(space.accept(remoteTuple(2, "big", "fits", 5), 100));
  CHECK_FALSE(space.withheld(2, "big"));
  CHECK(space.get(2, "big")->data == "fits");

  // A deletion, expiry and the owner's restart end a record too.
  REQUIRE(space.acceptWithheld(withheld(6, kSelf), 100));
  CHECK_FALSE(space.acceptDelete(2, "big", 7));  // nothing cached to delete...
  CHECK_FALSE(space.withheld(2, "big"));         // ...but the record is over
  auto expiring = withheld(8, kSelf);
  expiring.tuple.ts_expire = clock.now + 1s;
  REQUIRE(space.acceptWithheld(std::move(expiring), 100));
  clock.advance(2s);
  CHECK_FALSE(space.withheld(2, "big"));
  space.expire();
  REQUIRE(space.acceptWithheld(withheld(9, kSelf), 100));
  CHECK(space.withheld(2, "big"));
  CHECK(space.noteIncarnation(2, 200));
  CHECK_FALSE(space.withheld(2, "big"));
  CHECK_FALSE(space.acceptWithheld(withheld(10, kSelf), 100));  // of the old life
  CHECK_FALSE(space.acceptWithheld(TupleSpace::Withheld{remoteTuple(kSelf, "mine", "", 1)}, 0));

  space.dispatch();
  // Each cached value a newer record replaced left with a delete event.
  const std::vector<Seen> expected = {{"all", EventKind::Changed, "2.big", "small", 3},
                                      {"all", EventKind::Deleted, "2.big", "small", 4},
                                      {"all", EventKind::Changed, "2.big", "fits", 5},
                                      {"all", EventKind::Deleted, "2.big", "fits", 6}};
  CHECK(r.seen == expected);
}

TEST_CASE("a ttl too long for a timestamp saturates instead of wrapping into the past",
          "[unit][tuplespace]") {
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  peis::WriteOptions longest;
  longest.ttl = std::chrono::microseconds::max();
  const auto tuple = space.set("k", "v", longest);
  CHECK(tuple->ts_expire == Timestamp::max());
  CHECK(space.get(kSelf, "k"));
  CHECK(space.expire() == 0);
  CHECK(space.nextExpiry() == Timestamp::max());
}

TEST_CASE("a replaced tuple's storage is reused only when nobody holds it", "[unit][tuplespace]") {
  // docs/architecture.md, "Memory of a stream": the space writes new values
  // into tuples it stored before; one a caller, a queued delivery or a
  // callback still holds must never change under it.
  ManualClock clock;
  TupleSpace space(kSelf, [&] { return clock.now; });
  std::vector<std::string> seen;
  space.addCallback(Pattern("k"), peis::kOnChange,
                    [&](EventKind, const Tuple& t) { seen.push_back(t.data + "@" + t.key); });
  auto first = space.set("k", std::string(20, 'a'));
  std::vector<TuplePtr> held;
  for (int i = 0; i < 50; ++i) {
    auto t = space.set(i % 2 ? "k" : "other", std::string(static_cast<std::size_t>(i % 30), 'x'));
    if (i % 7 == 0) held.push_back(t);
    if (i % 5 == 0) {
      std::vector<TuplePtr> spent;
      while (auto delivery = space.nextDelivery()) {
        delivery->run();
        spent.push_back(delivery->takeTuple());
      }
      space.recycle(spent);
    }
  }
  space.dispatch();
  CHECK(first->data == std::string(20, 'a'));
  CHECK(first->seqno == 1);
  for (const auto& t : held) {
    const auto i = static_cast<int>(&t - held.data()) * 7;
    CHECK(t->key == (i % 2 ? "k" : "other"));
    CHECK(t->data == std::string(static_cast<std::size_t>(i % 30), 'x'));
  }
  // Every change of "k" delivered with its own value, in order.
  REQUIRE(seen.size() == 26);
  CHECK(seen.front() == std::string(20, 'a') + "@k");
  for (int n = 1; n < 26; ++n) {
    CHECK(seen[static_cast<std::size_t>(n)] ==
          std::string(static_cast<std::size_t>((2 * n - 1) % 30), 'x') + "@k");
  }
  CHECK(space.get(kSelf, "k")->data == std::string(19, 'x'));
}
