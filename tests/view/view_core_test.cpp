// peis-view's pure core: JSON, filters, the store's coalescing, what one
// page is sent, the graph, the protocol's messages, subscriptions, HTTP
// targets and pictures. No network, no kernel.
#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>

#include "camera/image_tuple.h"
#include "peis/error.h"
#include "view/client_state.h"
#include "view/filter.h"
#include "view/graph.h"
#include "view/http_target.h"
#include "view/image_convert.h"
#include "view/json.h"
#include "view/messages.h"
#include "view/rate_meter.h"
#include "view/subscriptions.h"
#include "view/tuple_store.h"

using namespace peis;
using namespace peis::view;
using namespace std::chrono_literals;

namespace {

const Timestamp kT0 = Timestamp(std::chrono::seconds(1'700'000'000));

Tuple tuple(PeisId owner, std::string key, std::string data, std::uint64_t seqno,
            std::string mimetype = "text/plain") {
  Tuple t;
  t.owner = owner;
  t.creator = owner;
  t.key = std::move(key);
  t.data = std::move(data);
  t.seqno = seqno;
  t.mimetype = std::move(mimetype);
  t.ts_write = kT0 + std::chrono::milliseconds(seqno);
  return t;
}

PeisId noNames(std::string_view name) {
  throw Error(ErrorCode::NotFound, "no PEIS is named '" + std::string(name) + "'");
}

Filter filter(const std::string& text) { return parseFilter(text, noNames); }

std::vector<Filter> filters(const std::string& text) { return {filter(text)}; }

view::json::Value parsed(const std::string& text) { return view::json::parse(text); }

}  // namespace

TEST_CASE("JSON strings are always valid UTF-8 and escaped", "[unit]") {
  CHECK(view::json::quote("a\"b\\c\n\t") == R"("a\"b\\c\n\t")");
  CHECK(view::json::quote(std::string("\x01", 1)) == R"("\u0001")");
  CHECK(view::json::quote("h\xC3\xA9") == "\"h\xC3\xA9\"");                // é stays
  CHECK(view::json::quote("x\xFFy") == "\"x\xEF\xBF\xBDy\"");              // a stray byte: U+FFFD
  CHECK(view::json::quote("\xC0\xAF") == "\"\xEF\xBF\xBD\xEF\xBF\xBD\"");  // an overlong '/'
  CHECK(view::json::quote("\xED\xA0\x80") ==
        "\"\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD\"");  // a surrogate
  CHECK(view::json::isValidUtf8(view::json::quote(std::string("\x80\x81\xfe\x00 ok", 8))));
  view::json::Writer w;
  w.beginObject()
      .key("a")
      .integer(-3)
      .key("b")
      .beginArray()
      .number(1.5)
      .boolean(true)
      .null()
      .endArray()
      .key("c")
      .number(std::numeric_limits<double>::infinity())
      .endObject();
  CHECK(w.text() == R"({"a":-3,"b":[1.5,true,null],"c":null})");
}

TEST_CASE("the JSON reader takes valid texts and says where others go wrong", "[unit]") {
  const auto v =
      parsed(R"( {"op":"set","n":-1.5e2,"ok":true,"none":null,"list":[1,"\u00e9\ud83d\ude00"]} )");
  REQUIRE(v.asObject());
  CHECK(*v.member("op")->asString() == "set");
  CHECK(*v.member("n")->asNumber() == -150);
  CHECK(*v.member("ok")->asBool());
  CHECK(v.member("none")->isNull());
  CHECK(v.member("missing") == nullptr);
  const auto& list = std::get<view::json::Array>(v.member("list")->v);
  CHECK(*list[1].asString() == "\xC3\xA9\xF0\x9F\x98\x80");

  auto fails = [](const std::string& text, const std::string& why) {
    INFO(text);
    CHECK_THROWS_WITH(view::json::parse(text), Catch::Contains(why));
  };
  fails("", "unexpected end");
  fails("{", "expected a member name");
  fails("{\"a\":1,}", "expected a member name");
  fails("[1 2]", "expected ']'");
  fails("\"abc", "unterminated string");
  fails("{} x", "unexpected text after the value at byte 3");
  fails("01", "unexpected text after the value");
  fails("\"\\x\"", "bad escape");
  fails("\"\\ud800\"", "lone surrogate");
  fails("\"a\tb\"", "control character");
  fails("\"\xFF\"", "invalid UTF-8");
  fails("1e999", "number out of range");
  fails(std::string(20, '[') + std::string(20, ']'), "nested deeper than 16 levels");
}

TEST_CASE("a filter is OWNER.KEYPATTERN with creator= and mimetype= after it", "[unit]") {
  const auto all = filter("");
  CHECK(all.text == "*.**");
  CHECK(all.matches(7, "a.b", 7, "text/plain"));

  const auto light = filter("  12.light.*  ");
  CHECK(light.text == "12.light.*");
  CHECK(light.matches(12, "light.reqState", 3, "text/plain"));
  CHECK_FALSE(light.matches(13, "light.reqState", 3, "text/plain"));
  CHECK_FALSE(light.matches(12, "light", 3, "text/plain"));

  const OwnerResolver names = [](std::string_view name) -> PeisId {
    if (name == "lamp") return 12;
    throw Error(ErrorCode::NotFound, "no PEIS is named '" + std::string(name) + "'");
  };
  const auto byName = parseFilter("lamp.** creator=lamp", names);
  CHECK(byName.matches(12, "x", 12, "a"));
  CHECK_FALSE(byName.matches(12, "x", 11, "a"));

  const auto images = filter("*.** mimetype=image/*");
  CHECK(images.matches(1, "image", 1, "image/x-raw;format=bgr8;width=2;height=2"));
  CHECK(images.matches(1, "photo", 1, "image/png"));
  CHECK_FALSE(images.matches(1, "photo", 1, "text/plain"));
  const auto exact = filter("*.* mimetype=image/png");
  CHECK_FALSE(exact.matches(1, "photo", 1, "image/pngx"));

  CHECK_THROWS_WITH(filter("status"), Catch::Contains("is not a pattern: write OWNER.KEYPATTERN"));
  CHECK_THROWS_WITH(filter("*.a..b"), Catch::Contains("bad key pattern 'a..b'"));
  CHECK_THROWS_WITH(filter("*.**.a"), Catch::Contains("bad key pattern"));
  CHECK_THROWS_WITH(parseFilter("sofa.x", names), Catch::Contains("no PEIS is named 'sofa'"));
  CHECK_THROWS_WITH(filter("*.x colour=red"), Catch::Contains("unknown filter option 'colour'"));
  CHECK_THROWS_WITH(filter("*.x mimetype"),
                    Catch::Contains("write creator=OWNER or mimetype=TYPE"));
  CHECK_THROWS_WITH(filter("9999999999.x"), Catch::Contains("neither a PEIS id nor a PEIS name"));
  CHECK_THROWS_WITH(filter(std::string(2000, '*')), Catch::Contains("over the 1024-byte limit"));
}

TEST_CASE("previews are cut at a character and binary data is never shown as text", "[unit]") {
  CHECK(makePreview("on", Encoding::Ascii, 10).text == "on");
  const auto cut = makePreview("ab\xC3\xA9", Encoding::Ascii, 3);  // é would be cut
  CHECK(cut.text == "ab");
  CHECK(cut.truncated);
  CHECK_FALSE(cut.binary);
  CHECK(makePreview(std::string("a\0b", 3), Encoding::Ascii, 10).binary);
  CHECK(makePreview("x\xFFy", Encoding::Ascii, 10).binary);
  CHECK(makePreview("text", Encoding::Binary, 10).binary);
  CHECK(makePreview("a\tb\r\n", Encoding::Ascii, 10).text == "a\tb\r\n");
  CHECK(parseNumber(" 42.5 ") == 42.5);
  CHECK(parseNumber("-1e3") == -1000);
  CHECK_FALSE(parseNumber("1,2"));
  CHECK_FALSE(parseNumber("nan"));
  CHECK_FALSE(parseNumber("0x10"));
  CHECK_FALSE(parseNumber(""));
  CHECK_FALSE(parseNumber("1e999"));
}

TEST_CASE("the store gives a page each changed tuple once, with its latest value", "[unit]") {
  TupleStore store;
  store.change(tuple(1, "a", "0", 1), kT0);
  store.change(tuple(1, "b", "x", 1), kT0);
  const auto first = store.changesSince(0, filters("*.**"), 100);
  CHECK(first.reset);
  CHECK(first.rows.size() == 2);
  CHECK_FALSE(first.more);

  // A burst of 100 writes of one tuple between two looks: one row.
  for (int i = 1; i <= 100; ++i) store.change(tuple(1, "a", std::to_string(i), i + 1), kT0 + 1s);
  const auto burst = store.changesSince(first.cursor, filters("*.**"), 100);
  CHECK_FALSE(burst.reset);
  REQUIRE(burst.rows.size() == 1);
  CHECK(burst.rows[0].key == "a");
  CHECK(burst.rows[0].preview == "100");
  CHECK(burst.rows[0].seqno == 101);
  CHECK(burst.rows[0].number == 100.0);
  CHECK(store.changesSince(burst.cursor, filters("*.**"), 100).rows.empty());

  // Only what the filter matches; the cursor still moves past the rest.
  store.change(tuple(2, "c", "1", 1), kT0 + 2s);
  store.change(tuple(1, "b", "y", 2), kT0 + 2s);
  const auto only2 = store.changesSince(burst.cursor, filters("2.*"), 100);
  REQUIRE(only2.rows.size() == 1);
  CHECK(only2.rows[0].owner == 2);
  CHECK(only2.cursor == store.version());

  // Deletions come as tombstones; a fresh page never sees them.
  store.remove(tuple(1, "b", "y", 3), kT0 + 3s);
  const auto deleted = store.changesSince(only2.cursor, filters("*.**"), 100);
  REQUIRE(deleted.rows.size() == 1);
  CHECK(deleted.rows[0].deleted);
  const auto fresh = store.changesSince(0, filters("*.**"), 100);
  CHECK(fresh.rows.size() == 2);
  for (const auto& row : fresh.rows) CHECK_FALSE(row.deleted);

  // A page whose cursor is older than a purged tombstone starts over.
  store.purgeTombstones(kT0 + 3s + 31s);
  CHECK(store.find(1, "b") == nullptr);
  CHECK(store.changesSince(only2.cursor, filters("*.**"), 100).reset);
  CHECK_FALSE(store.changesSince(deleted.cursor, filters("*.**"), 100).reset);
}

TEST_CASE("the store hands out at most maxRows rows and goes on from there", "[unit]") {
  TupleStore store;
  for (int i = 0; i < 25; ++i) store.change(tuple(1, "k" + std::to_string(i), "v", 1), kT0);
  std::uint64_t cursor = 0;
  std::size_t total = 0;
  int calls = 0;
  for (bool more = true; more; ++calls) {
    auto changes = store.changesSince(cursor, filters("*.**"), 10);
    CHECK(changes.rows.size() <= 10);
    total += changes.rows.size();
    cursor = changes.cursor;
    more = changes.more;
  }
  CHECK(total == 25);
  CHECK(calls == 3);
}

TEST_CASE("numeric tuples keep a bounded history, meta-level changes a bounded log", "[unit]") {
  StoreLimits limits;
  limits.historySamples = 5;
  limits.logEntries = 3;
  TupleStore store(limits);
  store.setLogFilters(filters("*.events.**"));
  for (int i = 1; i <= 8; ++i) store.change(tuple(1, "temp", std::to_string(i * 10), i), kT0);
  auto all = store.historySince(1, "temp", 0);
  CHECK(all.reset);
  REQUIRE(all.samples.size() == 5);
  CHECK(all.samples.front().value == 40);
  CHECK(all.samples.back().value == 80);
  CHECK(all.seen == 8);
  store.change(tuple(1, "temp", "90", 9), kT0);
  auto next = store.historySince(1, "temp", all.seen);
  CHECK_FALSE(next.reset);
  REQUIRE(next.samples.size() == 1);
  CHECK(next.samples[0].value == 90);
  store.change(tuple(1, "temp", "warm", 10), kT0);  // not a number: no sample
  CHECK(store.historySince(1, "temp", next.seen).samples.empty());

  // Every change of a logged tuple is kept, however fast (the table coalesces).
  store.change(tuple(5, "events.last", "failed tracker", 1), kT0);
  store.change(tuple(5, "events.last", "replanned", 2), kT0);
  store.change(tuple(5, "other", "x", 1), kT0);
  auto log = store.logSince(0, 10);
  REQUIRE(log.entries.size() == 2);
  CHECK(log.entries[0].tuple.preview == "failed tracker");
  CHECK(log.entries[1].tuple.preview == "replanned");
  store.change(tuple(5, "events.last", "deployed", 3), kT0);
  store.change(tuple(5, "events.last", "done", 4), kT0);
  auto late = store.logSince(log.last, 10);
  CHECK(late.entries.size() == 2);
  CHECK(store.logSince(0, 10).reset);  // the first entry was dropped from the bounded log
}

TEST_CASE("rates are measured from arrivals and fall when a tuple goes quiet", "[unit]") {
  RateMeter meter;
  CHECK(meter.rate(kT0) == 0.0);
  for (int i = 0; i <= 20; ++i) meter.add(kT0 + i * 100ms);
  CHECK(meter.rate(kT0 + 2s) == Approx(10.0));
  CHECK(meter.rate(kT0 + 4s) == Approx(5.0));
  CHECK(meter.rate(kT0 + 20s) == 0.0);
}

TEST_CASE("a page's updates: a snapshot, then only changes, each tuple once per update", "[unit]") {
  TupleStore store;
  store.setLogFilters(filters("*.config.**"));
  store.change(tuple(1, "light", "off", 1), kT0);
  store.change(tuple(1, "temp", "20", 1), kT0);
  store.change(tuple(2, "config.goals", "position(vac)", 1), kT0);
  ClientState page(filter("1.*"));
  auto graph = std::make_shared<const std::string>("{\"nodes\":[]}");

  Update first = page.collect(store, 1, graph, kT0);
  REQUIRE(first.table);
  CHECK(first.table->reset);
  CHECK(first.table->rows.size() == 2);
  CHECK(first.graphJson == *graph);
  REQUIRE(first.meta);
  CHECK(first.meta->rows.size() == 1);
  CHECK(first.logReset);
  CHECK(first.log.size() == 1);
  CHECK(page.collect(store, 1, graph, kT0 + 100ms).empty());

  for (int i = 2; i < 50; ++i) store.change(tuple(1, "light", i % 2 ? "on" : "off", i), kT0 + 1s);
  store.change(tuple(3, "elsewhere", "x", 1), kT0 + 1s);
  Update second = page.collect(store, 1, graph, kT0 + 1s);
  REQUIRE(second.table);
  REQUIRE(second.table->rows.size() == 1);
  CHECK(second.table->rows[0].seqno == 49);
  CHECK_FALSE(second.graphJson);
  const std::string encoded = encodeUpdate(second);
  const auto message = parsed(encoded);
  CHECK(*message.member("type")->asString() == "update");
  const auto& rows = std::get<view::json::Array>(message.member("table")->member("rows")->v);
  REQUIRE(rows.size() == 1);
  CHECK(*rows[0].member("id")->asString() == "1.light");
  CHECK(*rows[0].member("value")->asString() == "on");
  CHECK(*rows[0].member("seqno")->asNumber() == 49);

  // A new filter starts the table over; a new graph goes once.
  page.setFilter(filter("2.**"));
  Update third = page.collect(store, 2, graph, kT0 + 2s);
  REQUIRE(third.table);
  CHECK(third.table->reset);
  REQUIRE(third.table->rows.size() == 1);
  CHECK(third.table->rows[0].key == "config.goals");
  CHECK(third.graphJson);

  // The plot: every sample kept, not coalesced.
  page.setPlot(TupleRef{1, "temp"});
  for (int i = 2; i <= 6; ++i) store.change(tuple(1, "temp", std::to_string(20 + i), i), kT0 + 3s);
  Update fourth = page.collect(store, 2, graph, kT0 + 3s);
  REQUIRE(fourth.plot);
  CHECK(fourth.plot->reset);
  CHECK(fourth.plot->samples.size() == 6);
  store.change(tuple(1, "temp", "30", 7), kT0 + 4s);
  Update fifth = page.collect(store, 2, graph, kT0 + 4s);
  REQUIRE(fifth.plot);
  CHECK_FALSE(fifth.plot->reset);
  CHECK(fifth.plot->samples.size() == 1);
}

TEST_CASE("a page gets refreshed rates of rows that stopped changing", "[unit]") {
  TupleStore store;
  for (int i = 0; i < 10; ++i)
    store.change(tuple(1, "fast", std::to_string(i), i + 1), kT0 + i * 100ms);
  ClientState page(filter("*.**"));
  Update first = page.collect(store, 0, nullptr, kT0 + 1s);
  REQUIRE(first.table);
  CHECK(first.table->rates[0] > 5.0);
  Update later = page.collect(store, 0, nullptr, kT0 + 15s);
  REQUIRE(later.rates.size() == 1);
  CHECK(later.rates[0].first == "1.fast");
  CHECK(later.rates[0].second == 0.0);
}

TEST_CASE("the graph: PEIS, links once each, and the configuration resolved", "[unit]") {
  TupleStore store;
  store.change(tuple(11, "kernel.links", "12 99", 1), kT0);  // 99 is not reachable
  store.change(tuple(12, "kernel.links", "11 13", 1), kT0);
  store.change(tuple(13, "kernel.links", "12", 1), kT0);
  store.change(tuple(12, "status", "waiting", 1), kT0);
  store.change(tuple(12, "cause.names", "brightness", 1), kT0);
  store.change(tuple(12, "component.name", "lamp", 1), kT0);
  store.change(tuple(12, "mi-brightness", "sensor.brightness", 1, kMetaMimetype), kT0);
  store.change(tuple(12, "mi-left.cam1", "13.image", 1, kMetaMimetype), kT0);
  store.change(tuple(13, "mi-position", "77.position", 1), kT0);
  store.change(tuple(13, "mi-nothing", "", 1), kT0);
  store.change(tuple(99, "mi-x", "11.y", 1), kT0);  // owner not reachable: left out
  std::vector<PeerInfo> peers = {{13, "camera", 1, 0, false},
                                 {11, "sensor", 1, 0, false},
                                 {12, "lamp", 1, 0, false},
                                 {50, "peis-view", 0, 0, true}};
  const Graph g = buildGraph(peers, 50, store);
  REQUIRE(g.nodes.size() == 4);
  CHECK(g.nodes[0].id == 11);
  CHECK(g.nodes[3].self);
  CHECK(g.nodes[1].status == "waiting");
  CHECK(g.nodes[1].causes == "brightness");
  CHECK(g.nodes[1].component == "lamp");
  CHECK(g.links == std::vector<std::pair<PeisId, PeisId>>{{11, 12}, {12, 13}});
  REQUIRE(g.configuration.size() == 4);
  CHECK(g.configuration[0].consumer == 12);
  CHECK(g.configuration[0].metaKey == "mi-brightness");
  CHECK(g.configuration[0].producer == 11);
  CHECK(g.configuration[0].producerKey == "brightness");
  CHECK(g.configuration[0].producerReachable);
  CHECK(g.configuration[1].producer == 13);
  CHECK(g.configuration[2].metaKey == "mi-nothing");
  CHECK_FALSE(g.configuration[2].producer);
  CHECK(g.configuration[3].producer == 77);
  CHECK_FALSE(g.configuration[3].producerReachable);

  const auto message = parsed(encodeGraph(g, 50));
  CHECK(std::get<view::json::Array>(message.member("nodes")->v).size() == 4);
  CHECK(std::get<view::json::Array>(message.member("configuration")->v).size() == 4);

  CHECK_FALSE(resolveMetaValue("", peers));
  CHECK_FALSE(resolveMetaValue("nobody.x", peers));
  CHECK_FALSE(resolveMetaValue("11.bad..key", peers));
  peers.push_back({14, "lamp", 1, 0, false});
  CHECK_FALSE(resolveMetaValue("lamp.x", peers));  // two PEIS carry the name
}

TEST_CASE("a page's messages are decoded, and bad ones say what is wrong", "[unit]") {
  auto command = [](const std::string& text) { return decodeCommand(text, 100); };
  auto error = [&](const std::string& text) {
    auto decoded = command(text);
    REQUIRE(std::holds_alternative<CommandError>(decoded));
    return std::get<CommandError>(decoded);
  };
  auto filterCommand = command(R"({"op":"filter","pattern":"*.status"})");
  REQUIRE(std::holds_alternative<Command>(filterCommand));
  CHECK(std::get<FilterCommand>(std::get<Command>(filterCommand)).pattern == "*.status");
  auto set = std::get<SetCommand>(std::get<Command>(command(
      R"({"op":"set","request":7,"tuple":"lamp.light","value":"on","mimetype":"text/x"})")));
  CHECK(set.request == 7);
  CHECK(set.tuple == "lamp.light");
  CHECK(set.value == "on");
  CHECK(set.mimetype == "text/x");
  auto plotNone =
      std::get<PlotCommand>(std::get<Command>(command(R"({"op":"plot","tuple":null})")));
  CHECK_FALSE(plotNone.tuple);

  CHECK_THAT(error("hello").message,
             Catch::StartsWith("the message is not JSON: unexpected character at byte 0"));
  CHECK_THAT(error("[1]").message, Catch::Contains("must be a JSON object, not an array"));
  CHECK_THAT(error("{}").message, Catch::Contains("needs \"op\""));
  const auto unknown = error(R"({"op":"frobnicate","request":3})");
  CHECK_THAT(unknown.message,
             Catch::Contains("unknown op 'frobnicate' (known: filter, plot, get, set)"));
  CHECK(unknown.request == 3u);
  CHECK_THAT(error(R"({"op":"filter"})").message, Catch::Contains("'filter' needs \"pattern\""));
  CHECK_THAT(error(R"({"op":"filter","pattern":5})").message,
             Catch::Contains("must be a string, not a number"));
  CHECK_THAT(error(R"({"op":"set","tuple":"a.b","value":"x"})").message,
             Catch::Contains("needs \"request\""));
  CHECK_THAT(error(R"({"op":"set","request":-1,"tuple":"a.b","value":"x"})").message,
             Catch::Contains("whole number"));
  CHECK_THAT(error(R"({"op":"set","request":1.5,"tuple":"a.b","value":"x"})").message,
             Catch::Contains("whole number"));
  const auto huge =
      error(R"({"op":"set","request":2,"tuple":"a.b","value":")" + std::string(101, 'x') + "\"}");
  CHECK_THAT(huge.message,
             Catch::Contains("a value of 101 bytes is over this view's edit limit of 100 bytes"));
  CHECK(huge.request == 2u);
  CHECK(huge.op == "set");

  const auto reply = parsed(encodeReplyError(4, "set", "12.x", "PEIS 12: too large", "too large"));
  CHECK(*reply.member("ok")->asBool() == false);
  CHECK(*reply.member("error")->asString() == "PEIS 12: too large");
  const auto err = parsed(encodeError(huge));
  CHECK(*err.member("type")->asString() == "error");
  CHECK(*err.member("request")->asNumber() == 2);
  const auto ok = parsed(encodeGetReply(5, "12.x", "v\xFF", "text/plain", 3));
  CHECK(*ok.member("value")->asString() == "v\xEF\xBF\xBD");
}

TEST_CASE("subscriptions are shared, and linger before they end", "[unit]") {
  std::vector<std::string> log;
  std::uint64_t next = 1;
  std::map<std::uint64_t, std::string> handles;
  {
    SubscriptionSet set(
        [&](const Pattern& p) {
          handles[next] = p.str();
          log.push_back("+" + p.str());
          return next++;
        },
        [&](std::uint64_t h) { log.push_back("-" + handles[h]); }, 10s);
    const auto t = std::chrono::steady_clock::time_point() + 1h;
    const auto a = set.acquire(Pattern("light.*", 12), t);
    const auto b = set.acquire(Pattern("light.*", 12).creator(3), t);  // same on the wire
    CHECK(a == b);
    CHECK(set.wanted(a) == 2);
    set.release(a, t);
    set.release(b, t + 1s);
    set.expire(t + 5s);
    CHECK(set.active() == 1);  // lingers
    set.acquire(Pattern("light.*", 12), t + 6s);
    set.expire(t + 20s);
    CHECK(set.active() == 1);  // wanted again
    set.acquire(Pattern("status"), t + 20s);
    set.release(a, t + 20s);
    set.expire(t + 31s);
    CHECK(set.active() == 1);
  }
  CHECK(log == std::vector<std::string>{"+12.light.*", "+*.status", "-12.light.*", "-*.status"});
}

TEST_CASE("HTTP targets and the local-only checks", "[unit]") {
  CHECK(percentDecode("12.image%2Ex+y") == "12.image.x y");
  CHECK_FALSE(percentDecode("%4"));
  CHECK_FALSE(percentDecode("%zz"));
  CHECK(queryParameter("tuple=12.image&seqno=3", "tuple") == "12.image");
  CHECK(queryParameter("seqno=3&tuple=lamp%2Eimage", "tuple") == "lamp.image");
  CHECK_FALSE(queryParameter("seqno=3", "tuple"));
  CHECK(isLocalHost("127.0.0.1:7780"));
  CHECK(isLocalHost("localhost"));
  CHECK(isLocalHost("[::1]:80"));
  CHECK_FALSE(isLocalHost("evil.example:7780"));
  CHECK_FALSE(isLocalHost("127.0.0.1.evil.example"));
  CHECK_FALSE(isLocalHost("[::1]x"));
  CHECK(isLocalOrigin(""));
  CHECK(isLocalOrigin("http://127.0.0.1:7780"));
  CHECK_FALSE(isLocalOrigin("https://evil.example"));
  CHECK_FALSE(isLocalOrigin("http://evil.example:7780"));
  CHECK_FALSE(isLocalOrigin("null"));
}

TEST_CASE("raw camera images become PNG, what is not a picture is refused", "[unit]") {
  cv::Mat image(4, 6, CV_8UC3, cv::Scalar(10, 200, 30));
  const auto raw = camera::encodeImage(image, camera::ImageFormat::Raw);
  std::string why;
  const auto picture = toPicture(raw.mimetype, raw.data, why);
  REQUIRE(picture);
  CHECK(picture->mimetype == "image/png");
  const cv::Mat back = cv::imdecode(
      std::vector<unsigned char>(picture->data.begin(), picture->data.end()), cv::IMREAD_COLOR);
  REQUIRE(back.cols == 6);
  CHECK(back.at<cv::Vec3b>(2, 3) == cv::Vec3b(10, 200, 30));
  CHECK(isPictureMimetype(raw.mimetype));

  const auto png = toPicture("image/png", "\x89PNG...", why);
  REQUIRE(png);
  CHECK(png->data == "\x89PNG...");
  CHECK_FALSE(toPicture("text/plain", "x", why));
  CHECK_THAT(why, Catch::Contains("is not a picture this view shows"));
  CHECK_FALSE(toPicture("image/svg+xml", "<svg/>", why));
  CHECK_FALSE(toPicture(raw.mimetype, raw.data.substr(1), why));
  CHECK_FALSE(why.empty());
}
