// Wire codec: every message type round-trips, the bytes are exactly the
// big-endian layout of wire_format.h / docs/protocol.md, and the decoder
// rejects every malformed frame with a reason instead of crashing.
#include "net/wire.h"

#include <catch2/catch.hpp>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "peis/error.h"

namespace peis::wire {
namespace {

constexpr std::size_t kLimit = 1024;

// "00 0a ff" -> the three bytes.
std::string hex(std::string_view text) {
  std::string out;
  int nibbles = 0;
  unsigned value = 0;
  for (char c : text) {
    if (c == ' ') continue;
    const unsigned digit = c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10;
    value = (value << 4) | digit;
    if (++nibbles == 2) {
      out.push_back(static_cast<char>(value));
      nibbles = 0;
      value = 0;
    }
  }
  return out;
}

std::string frameOf(const LinkMessage& message) {
  std::string out;
  encode(message, out);
  return out;
}

std::string frameOf(const RoutedMessage& message) {
  std::string out;
  encode(message, out);
  return out;
}

// The bytes decode() takes: the frame without its u32 length.
std::string_view bodyOf(const std::string& frame) {
  return std::string_view(frame).substr(kFrameHeaderBytes);
}

Message decodeOk(const std::string& frame, std::size_t limit = kLimit) {
  REQUIRE(frame.size() >= kFrameHeaderBytes);
  REQUIRE(frameLength(frame) == frame.size() - kFrameHeaderBytes);
  auto result = decode(bodyOf(frame), limit);
  INFO(result.error);
  REQUIRE(result.message);
  CHECK(result.error.empty());
  return std::move(*result.message);
}

std::string rejectBody(std::string_view body, std::size_t limit = kLimit) {
  const auto result = decode(body, limit);
  CHECK_FALSE(result.message);
  CHECK_FALSE(result.error.empty());
  return result.error;
}

std::string rejectFrame(const std::string& frame) { return rejectBody(bodyOf(frame)); }

template <typename T>
void checkLinkRoundTrip(const T& message) {
  const auto decoded = decodeOk(frameOf(LinkMessage{message}));
  REQUIRE(std::holds_alternative<LinkMessage>(decoded));
  const auto& link = std::get<LinkMessage>(decoded);
  REQUIRE(std::holds_alternative<T>(link));
  CHECK(std::get<T>(link) == message);
}

void checkRoutedRoundTrip(const RoutedMessage& message) {
  const auto decoded = decodeOk(frameOf(message));
  REQUIRE(std::holds_alternative<RoutedMessage>(decoded));
  CHECK(std::get<RoutedMessage>(decoded) == message);
}

Timestamp at(std::int64_t micros) { return Timestamp(std::chrono::microseconds(micros)); }

Tuple sampleTuple() {
  Tuple t;
  t.owner = 7;
  t.creator = 12;
  t.key = "robot.position.x";
  t.data = "3.25";
  t.mimetype = "text/plain";
  t.encoding = Encoding::Ascii;
  t.ts_write = at(1'700'000'000'000'001);
  t.ts_user = at(-5);
  t.ts_expire = at(1'700'000'060'000'000);
  t.seqno = 42;
  return t;
}

Envelope sampleEnvelope() { return Envelope{7, 3, 17}; }

Hello sampleHello() {
  Hello h;
  h.ecology = "lab";
  h.id = 7;
  h.incarnation = 0x0102030405060708ull;
  h.name = "astrid";
  h.listenPort = 4711;
  h.capabilities = kCapabilityCoalescing;
  h.auth = "";
  return h;
}

// One valid frame of every type (both variants where a type has two).
std::vector<std::pair<std::string, std::string>> sampleFrames() {
  std::vector<std::pair<std::string, std::string>> frames;
  auto hello = sampleHello();
  hello.auth = "token";
  frames.emplace_back("Hello", frameOf(LinkMessage{hello}));
  frames.emplace_back("Ping", frameOf(LinkMessage{Ping{99}}));
  frames.emplace_back("Pong", frameOf(LinkMessage{Pong{98}}));
  frames.emplace_back("Routes (empty)", frameOf(LinkMessage{Routes{}}));
  frames.emplace_back(
      "Routes", frameOf(LinkMessage{Routes{{{7, 0, 0, 70, 3, "astrid"}, {8, 2, 1, 80, 0, ""}}}}));
  frames.emplace_back("IdTaken", frameOf(LinkMessage{IdTaken{7, 70}}));
  frames.emplace_back("Leave", frameOf(LinkMessage{Leave{7, 70}}));
  frames.emplace_back("SeqnoRequest", frameOf(LinkMessage{SeqnoRequest{7, 70, 3, 32}}));
  frames.emplace_back("Auth", frameOf(LinkMessage{Auth{"identity", std::string(64, 's')}}));
  frames.emplace_back("Identity", frameOf(LinkMessage{Identity{"identity"}}));
  frames.emplace_back("SourceTag", frameOf(LinkMessage{SourceTag{std::string(16, 't')}}));
  const auto env = sampleEnvelope();
  frames.emplace_back("Subscribe (owner)",
                      frameOf(RoutedMessage{env, Subscribe{5, 6000, PeisId{7}, "robot.*.x"}}));
  frames.emplace_back("Subscribe (any owner)",
                      frameOf(RoutedMessage{env, Subscribe{6, 6000, std::nullopt, "**"}}));
  frames.emplace_back("Unsubscribe", frameOf(RoutedMessage{env, Unsubscribe{5}}));
  frames.emplace_back("TupleUpdate", frameOf(RoutedMessage{env, TupleUpdate{70, sampleTuple()}}));
  frames.emplace_back("TupleDeleted",
                      frameOf(RoutedMessage{env, TupleDeleted{70, 7, "robot.position.x", 43}}));
  frames.emplace_back(
      "Write", frameOf(RoutedMessage{env, Write{9, WriteOp::Append, 41u, 500, sampleTuple()}}));
  frames.emplace_back("WriteResult", frameOf(RoutedMessage{env, WriteResult{9, 7, 0, "conflict"}}));
  auto head = sampleTuple();
  head.data.clear();
  frames.emplace_back("KeyManifest",
                      frameOf(RoutedMessage{env, KeyManifest{70, 5, 10, 900, {10, 11, 900}}}));
  frames.emplace_back("TupleWithheld",
                      frameOf(RoutedMessage{env, TupleWithheld{70, 3, 1000, 5000, head}}));
  return frames;
}

}  // namespace

TEST_CASE("wire: link messages round-trip", "[unit][wire]") {
  SECTION("Hello") {
    checkLinkRoundTrip(sampleHello());
    auto h = sampleHello();
    h.name = "";  // a PEIS may announce no name
    h.auth = std::string("\0\x01secret", 8);
    h.capabilities = 0xffffffffu;
    h.listenPort = 65535;
    h.incarnation = ~0ull;
    h.id = kMaxPeisId;
    checkLinkRoundTrip(h);
    h.version = 1;  // the decoder passes other versions on; the handshake refuses them
    checkLinkRoundTrip(h);
  }
  SECTION("Ping and Pong") {
    checkLinkRoundTrip(Ping{0});
    checkLinkRoundTrip(Ping{0xfedcba9876543210ull});
    checkLinkRoundTrip(Pong{0});
    checkLinkRoundTrip(Pong{~0ull});
  }
  SECTION("Routes") {
    checkLinkRoundTrip(Routes{});
    checkLinkRoundTrip(Routes{
        {{1, 0, 0, 10, 0, "a"}, {kMaxPeisId, 32, 0xff, ~0ull, ~0u, ""}, {5, 255, 1, 0, 7, "bob"}}});
  }
  SECTION("Auth, Identity, SourceTag (secured ecologies)") {
    CHECK(frameOf(LinkMessage{Auth{"ab", std::string(64, '\x11')}}) ==
          hex("00 00 00 45 08 00 02 61 62") + std::string(64, '\x11'));
    CHECK(frameOf(LinkMessage{Identity{"ab"}}) == hex("00 00 00 05 09 00 02 61 62"));
    CHECK(frameOf(LinkMessage{SourceTag{std::string(16, '\x22')}}) ==
          hex("00 00 00 11 0a") + std::string(16, '\x22'));
  }
  SECTION("IdTaken") {
    checkLinkRoundTrip(IdTaken{1, 0});
    checkLinkRoundTrip(IdTaken{kMaxPeisId, ~0ull});
  }
  SECTION("Leave and SeqnoRequest") {
    checkLinkRoundTrip(Leave{1, 0});
    checkLinkRoundTrip(Leave{kMaxPeisId, ~0ull});
    checkLinkRoundTrip(SeqnoRequest{1, 0, 0, 0});
    checkLinkRoundTrip(SeqnoRequest{kMaxPeisId, ~0ull, ~0u, 255});
  }
}

TEST_CASE("wire: routed messages round-trip", "[unit][wire]") {
  const auto env = sampleEnvelope();
  SECTION("Subscribe with and without owner") {
    checkRoutedRoundTrip(RoutedMessage{env, Subscribe{1, 6000, PeisId{7}, "a.b"}});
    checkRoutedRoundTrip(RoutedMessage{env, Subscribe{~0ull, 0, std::nullopt, "*.x.**"}});
    checkRoutedRoundTrip(RoutedMessage{Envelope{1, kMaxPeisId, 1}, Subscribe{2, ~0u, 1, "**"}});
    Subscribe limited{3, 6000, PeisId{7}, "a.b", 2, 9, 0};  // a limit of 0 bytes is a limit
    checkRoutedRoundTrip(RoutedMessage{env, limited});
  }
  SECTION("Unsubscribe") {
    checkRoutedRoundTrip(RoutedMessage{env, Unsubscribe{0}});
    checkRoutedRoundTrip(RoutedMessage{env, Unsubscribe{~0ull}});
  }
  SECTION("TupleUpdate, including binary data with NUL bytes") {
    checkRoutedRoundTrip(RoutedMessage{env, TupleUpdate{70, sampleTuple()}});
    auto t = sampleTuple();
    t.data = std::string("\0\x01\x02\0\xff\x80\0", 7);
    t.encoding = Encoding::Binary;
    t.mimetype = "application/octet-stream";
    t.ts_write = kNoTime;
    t.ts_user = kNoTime;
    t.ts_expire = kNoTime;
    t.seqno = ~0ull;
    checkRoutedRoundTrip(RoutedMessage{env, TupleUpdate{~0ull, t}});
    t.data.clear();
    t.mimetype.clear();
    checkRoutedRoundTrip(RoutedMessage{env, TupleUpdate{0, t}});
    t.data = std::string(kLimit, '\0');  // exactly the limit is accepted
    checkRoutedRoundTrip(RoutedMessage{env, TupleUpdate{1, t}});
  }
  SECTION("TupleDeleted") {
    checkRoutedRoundTrip(RoutedMessage{env, TupleDeleted{70, 7, "robot.position.x", 43}});
    checkRoutedRoundTrip(RoutedMessage{env, TupleDeleted{0, kMaxPeisId, "k", 0}});
  }
  SECTION("Write with each op, with and without if-seqno") {
    for (auto op : {WriteOp::Set, WriteOp::Append, WriteOp::Erase}) {
      for (std::optional<std::uint64_t> ifSeqno :
           {std::optional<std::uint64_t>{}, std::optional<std::uint64_t>{0},
            std::optional<std::uint64_t>{123}}) {
        for (std::int64_t ttl : {std::int64_t{0}, std::int64_t{2'000'000}}) {
          INFO("op " << static_cast<int>(op) << " ttl " << ttl);
          auto t = sampleTuple();
          t.data = std::string("x\0y", 3);
          checkRoutedRoundTrip(RoutedMessage{env, Write{77, op, ifSeqno, ttl, t}});
          checkRoutedRoundTrip(RoutedMessage{env, Write{77, op, ifSeqno, ttl, t, ~0u}});
        }
      }
    }
  }
  SECTION("TupleWithheld: the tuple without its data, with the size it has") {
    auto head = sampleTuple();
    head.data.clear();
    checkRoutedRoundTrip(RoutedMessage{env, TupleWithheld{70, 3, 1000, 5000, head}});
    checkRoutedRoundTrip(
        RoutedMessage{env, TupleWithheld{~0ull, kMaxPeisId, 0, 0x7fffffffu, head}});
  }
  SECTION("KeyManifest: empty, and a whole range of hashes") {
    checkRoutedRoundTrip(RoutedMessage{env, KeyManifest{70, 5, 0, UINT64_MAX, {}}});
    std::vector<std::uint64_t> hashes;
    for (std::uint64_t i = 0; i < kMaxManifestHashes; ++i) hashes.push_back(i * 3 + 1);
    checkRoutedRoundTrip(RoutedMessage{env, KeyManifest{~0ull, ~0ull, 1, 7000, hashes}});
  }
  SECTION("WriteResult") {
    checkRoutedRoundTrip(RoutedMessage{env, WriteResult{1, 0, 5, ""}});
    checkRoutedRoundTrip(RoutedMessage{
        env,
        WriteResult{~0ull, static_cast<std::uint8_t>(static_cast<int>(ErrorCode::Conflict) + 1), 0,
                    "expected seqno 3 but it is 4"}});
  }
}

TEST_CASE("wire: byte layout is big-endian and exact", "[unit][wire]") {
  SECTION("Ping nonce") {
    CHECK(frameOf(LinkMessage{Ping{0x0102030405060708ull}}) ==
          hex("00 00 00 09 02 01 02 03 04 05 06 07 08"));
    CHECK(frameOf(LinkMessage{Pong{0x0102030405060708ull}}) ==
          hex("00 00 00 09 03 01 02 03 04 05 06 07 08"));
  }
  SECTION("Auth, Identity, SourceTag (secured ecologies)") {
    CHECK(frameOf(LinkMessage{Auth{"ab", std::string(64, '\x11')}}) ==
          hex("00 00 00 45 08 00 02 61 62") + std::string(64, '\x11'));
    CHECK(frameOf(LinkMessage{Identity{"ab"}}) == hex("00 00 00 05 09 00 02 61 62"));
    CHECK(frameOf(LinkMessage{SourceTag{std::string(16, '\x22')}}) ==
          hex("00 00 00 11 0a") + std::string(16, '\x22'));
  }
  SECTION("IdTaken") {
    CHECK(frameOf(LinkMessage{IdTaken{0x01020304, 0x1122334455667788ull}}) ==
          hex("00 00 00 0d 05 01 02 03 04 11 22 33 44 55 66 77 88"));
  }
  SECTION("Hello") {
    Hello h;
    h.ecology = "eco";
    h.id = 7;
    h.incarnation = 0x1122334455667788ull;
    h.name = "n";
    h.listenPort = 8080;
    h.capabilities = 1;
    h.auth = "";
    CHECK(frameOf(LinkMessage{h}) == hex("00 00 00 21 01"
                                         "50 45 49 53"              // magic "PEIS"
                                         "00 03"                    // version
                                         "03 65 63 6f"              // str8 "eco"
                                         "00 00 00 07"              // id
                                         "11 22 33 44 55 66 77 88"  // incarnation
                                         "01 6e"                    // str8 "n"
                                         "1f 90"                    // port 8080
                                         "00 00 00 01"              // capabilities
                                         "00 00"));                 // str16 auth ""
  }
  SECTION("Routes") {
    CHECK(frameOf(LinkMessage{Routes{{{0x0a0b0c0d, 3, 1, 0x0102030405060708ull, 0xa1a2a3a4,
                                       "ab"}}}}) == hex("00 00 00 18 04 00 01"
                                                        "0a 0b 0c 0d 03 01"  // id, hops, flags
                                                        "01 02 03 04 05 06 07 08"  // incarnation
                                                        "a1 a2 a3 a4"              // seqno
                                                        "02 61 62"));              // str8 "ab"
  }
  SECTION("Leave and SeqnoRequest") {
    CHECK(frameOf(LinkMessage{Leave{0x01020304, 0x1122334455667788ull}}) ==
          hex("00 00 00 0d 06 01 02 03 04 11 22 33 44 55 66 77 88"));
    CHECK(frameOf(LinkMessage{SeqnoRequest{0x01020304, 0x1122334455667788ull, 0xa1a2a3a4, 9}}) ==
          hex("00 00 00 12 07 01 02 03 04 11 22 33 44 55 66 77 88 a1 a2 a3 a4 09"));
  }
  SECTION("envelope and Unsubscribe") {
    CHECK(frameOf(RoutedMessage{Envelope{1, kMaxPeisId, 32}, Unsubscribe{0xa1a2a3a4a5a6a7a8ull}}) ==
          hex("00 00 00 12 11 00 00 00 01 7f ff ff ff 20 a1 a2 a3 a4 a5 a6 a7 a8"));
  }
  SECTION("Subscribe without owner writes owner 0") {
    CHECK(frameOf(RoutedMessage{Envelope{2, 3, 4}, Subscribe{5, 6000, std::nullopt, "a.*"}}) ==
          hex("00 00 00 30 10 00 00 00 02 00 00 00 03 04"
              "00 00 00 00 00 00 00 05"  // subscription
              "00 00 17 70"              // lease 6000
              "00 00 00 00 00"           // no owner, owner 0
              "00 03 61 2e 2a"           // str16 "a.*"
              "00 00 00 00"              // known count
              "00 00 00 00 00 00 00 00"  // known digest
              "ff ff ff ff"));           // max data: none announced
  }
  SECTION("TupleUpdate with its tuple") {
    Tuple t;
    t.owner = 2;
    t.creator = 3;
    t.key = "k";
    t.mimetype = "m";
    t.encoding = Encoding::Binary;
    t.ts_write = at(0x0102);
    t.ts_user = at(-1);
    t.ts_expire = kNoTime;
    t.seqno = 9;
    t.data = std::string("\0z", 2);
    const auto expected =
        hex("00 00 00 46 12 00 00 00 02 00 00 00 05 20"
            "00 00 00 00 00 00 00 0a"  // owner incarnation
            "00 00 00 02 00 00 00 03"  // owner, creator
            "00 01 6b 01 6d 01"        // str16 "k", str8 "m", encoding binary
            "00 00 00 00 00 00 01 02"  // ts_write
            "ff ff ff ff ff ff ff ff"  // ts_user -1
            "00 00 00 00 00 00 00 00"  // ts_expire unset
            "00 00 00 00 00 00 00 09"  // seqno
            "00 00 00 02 00 7a");      // bytes32 data
    CHECK(frameOf(RoutedMessage{Envelope{2, 5, 32}, TupleUpdate{10, t}}) == expected);
  }
  SECTION("Write flags, op and ttl") {
    Tuple t;
    t.owner = 2;
    t.creator = 3;
    t.key = "k";
    t.mimetype = "";
    const auto frame = frameOf(
        RoutedMessage{Envelope{3, 2, 32}, Write{0x10, WriteOp::Erase, 0x0fu, 256, t, 5000}});
    const auto body = bodyOf(frame);
    // type | envelope (9) | request (8) | op | has if | if-seqno | ttl | wait | tuple
    CHECK(body.substr(0, 1) == hex("14"));
    CHECK(body.substr(10, 8) == hex("00 00 00 00 00 00 00 10"));
    CHECK(body.substr(18, 2) == hex("02 01"));
    CHECK(body.substr(20, 8) == hex("00 00 00 00 00 00 00 0f"));
    CHECK(body.substr(28, 8) == hex("00 00 00 00 00 00 01 00"));
    CHECK(body.substr(36, 4) == hex("00 00 13 88"));  // wait 5000 ms
    CHECK(body.substr(40, 4) == hex("00 00 00 02"));  // the tuple's owner
  }
  SECTION("TupleWithheld") {
    Tuple t;
    t.owner = 2;
    t.creator = 3;
    t.key = "k";
    t.mimetype = "m";
    t.seqno = 9;
    CHECK(frameOf(RoutedMessage{Envelope{9, 5, 32}, TupleWithheld{10, 9, 1000, 70000, t}}) ==
          hex("00 00 00 4c 16 00 00 00 09 00 00 00 05 20"
              "00 00 00 00 00 00 00 0a"  // owner incarnation
              "00 00 00 09"              // limited by PEIS 9
              "00 00 03 e8"              // its limit, 1000
              "00 00 00 02 00 00 00 03"  // owner, creator
              "00 01 6b 01 6d 00"        // str16 "k", str8 "m", encoding ascii
              "00 00 00 00 00 00 00 00"  // ts_write
              "00 00 00 00 00 00 00 00"  // ts_user
              "00 00 00 00 00 00 00 00"  // ts_expire
              "00 00 00 00 00 00 00 09"  // seqno
              "00 01 11 70"));           // the data's length, 70000; no data bytes
  }
  SECTION("TupleDeleted and WriteResult") {
    CHECK(frameOf(RoutedMessage{Envelope{2, 3, 1}, TupleDeleted{1, 2, "ab", 0x0304}}) ==
          hex("00 00 00 22 13 00 00 00 02 00 00 00 03 01"
              "00 00 00 00 00 00 00 01 00 00 00 02 00 02 61 62 00 00 00 00 00 00 03 04"));
    CHECK(frameOf(RoutedMessage{Envelope{2, 3, 1}, WriteResult{1, 7, 2, "no"}}) ==
          hex("00 00 00 1f 15 00 00 00 02 00 00 00 03 01"
              "00 00 00 00 00 00 00 01 07 00 00 00 00 00 00 00 02 00 02 6e 6f"));
  }
}

TEST_CASE("wire: encoder helpers agree with encode()", "[unit][wire]") {
  const auto t = sampleTuple();
  SECTION("encodeTupleUpdate equals encode of the same TupleUpdate") {
    std::string direct;
    encodeTupleUpdate(sampleEnvelope(), 70, t, direct);
    CHECK(direct == frameOf(RoutedMessage{sampleEnvelope(), TupleUpdate{70, t}}));
    auto binary = t;
    binary.data = std::string("\0\0\0", 3);
    binary.encoding = Encoding::Binary;
    std::string second;
    encodeTupleUpdate(Envelope{1, 2, 3}, 0, binary, second);
    CHECK(second == frameOf(RoutedMessage{Envelope{1, 2, 3}, TupleUpdate{0, binary}}));
  }
  SECTION("encodeFrame equals encode") {
    const RoutedMessage m{sampleEnvelope(), Subscribe{5, 6000, PeisId{7}, "a.**"}};
    CHECK(encodeFrame(m) == frameOf(m));
  }
  SECTION("encode appends whole frames") {
    std::string out = "xy";
    encode(LinkMessage{Ping{1}}, out);
    encode(RoutedMessage{sampleEnvelope(), Unsubscribe{2}}, out);
    REQUIRE(out.size() == 2 + 13 + 22);
    CHECK(out.substr(0, 2) == "xy");
    CHECK(frameLength(out.substr(2)) == 9);
    CHECK(frameLength(out.substr(15)) == 18);
    CHECK(std::get<RoutedMessage>(decodeOk(out.substr(15))).body == RoutedBody{Unsubscribe{2}});
  }
  SECTION("reEnvelope rewrites only the envelope") {
    auto frame = frameOf(RoutedMessage{sampleEnvelope(), TupleUpdate{70, t}});
    const Envelope other{9, kMaxPeisId, 1};
    reEnvelope(frame, other);
    CHECK(frame == frameOf(RoutedMessage{other, TupleUpdate{70, t}}));
    const auto decoded = std::get<RoutedMessage>(decodeOk(frame));
    CHECK(decoded.envelope == other);
    CHECK(decoded.body == RoutedBody{TupleUpdate{70, t}});
  }
  SECTION("frameLength reads a big-endian u32") {
    CHECK(frameLength(hex("01 02 03 04 ff")) == 0x01020304u);
    CHECK(frameLength(hex("ff ff ff ff")) == 0xffffffffu);
  }
}

TEST_CASE("wire: malformed frames are rejected with a reason", "[unit][wire]") {
  const auto env = sampleEnvelope();

  SECTION("empty frame") { CHECK(rejectBody(std::string_view{}) == "empty frame"); }

  SECTION("unknown message types") {
    for (int type : {0, 11, 12, 15, 24, 127, 255}) {
      INFO("type " << type);
      std::string body(1, static_cast<char>(type));
      CHECK(rejectBody(body).find("unknown message type") != std::string::npos);
      body.append(40, '\x01');
      CHECK(rejectBody(body).find("unknown message type") != std::string::npos);
    }
  }

  SECTION("every truncation of every valid frame") {
    for (const auto& [name, frame] : sampleFrames()) {
      const auto body = bodyOf(frame);
      INFO(name);
      REQUIRE(decode(body, kLimit).message);
      for (std::size_t length = 0; length < body.size(); ++length) {
        INFO("prefix of " << length << " of " << body.size() << " bytes");
        rejectBody(body.substr(0, length));
      }
    }
  }

  SECTION("trailing bytes after every valid frame") {
    for (const auto& [name, frame] : sampleFrames()) {
      INFO(name);
      for (std::size_t extra : {1u, 7u}) {
        std::string body(bodyOf(frame));
        body.append(extra, '\0');
        CHECK(rejectBody(body).find("trailing") != std::string::npos);
      }
    }
  }

  SECTION("tuple data over the limit or over the frame") {
    auto t = sampleTuple();
    t.data = std::string(kLimit + 1, 'd');
    const auto tooBig = frameOf(RoutedMessage{env, TupleUpdate{70, t}});
    CHECK(rejectBody(bodyOf(tooBig), kLimit).find("exceeds the limit") != std::string::npos);
    CHECK(decode(bodyOf(tooBig), kLimit + 1).message);
    CHECK(rejectBody(bodyOf(frameOf(RoutedMessage{env, Write{1, WriteOp::Set, {}, 0, t}})), kLimit)
              .find("exceeds the limit") != std::string::npos);

    // A data length larger than what follows (but within the limit).
    t.data = "abcd";
    auto frame = frameOf(RoutedMessage{env, TupleUpdate{70, t}});
    const auto lengthAt = frame.size() - t.data.size() - 4;
    REQUIRE(frame.substr(lengthAt, 4) == hex("00 00 00 04"));
    frame[lengthAt + 3] = 5;
    CHECK(rejectBody(bodyOf(frame)).find("truncated") != std::string::npos);
    // A huge length is refused by the limit before anything is read.
    frame.replace(lengthAt, 4, hex("ff ff ff ff"));
    CHECK(rejectBody(bodyOf(frame)).find("exceeds the limit") != std::string::npos);
    CHECK(rejectBody(bodyOf(frame), ~std::size_t{0}).find("truncated") != std::string::npos);
  }

  SECTION("a KeyManifest out of order, outside its range, too long or with an empty range") {
    const auto reason = [&](KeyManifest m) { return rejectFrame(frameOf(RoutedMessage{env, m})); };
    CHECK(reason(KeyManifest{1, 2, 0, 100, {5, 5}}).find("not ascending") != std::string::npos);
    CHECK(reason(KeyManifest{1, 2, 0, 100, {7, 5}}).find("not ascending") != std::string::npos);
    CHECK(reason(KeyManifest{1, 2, 10, 100, {5}}).find("outside its range") != std::string::npos);
    CHECK(reason(KeyManifest{1, 2, 10, 100, {101}}).find("outside its range") != std::string::npos);
    CHECK(reason(KeyManifest{1, 2, 100, 10, {}}).find("empty key hash range") != std::string::npos);
    std::vector<std::uint64_t> tooMany(kMaxManifestHashes + 1);
    for (std::size_t i = 0; i < tooMany.size(); ++i) tooMany[i] = i;
    CHECK(reason(KeyManifest{1, 2, 0, UINT64_MAX, tooMany}).find("too many") != std::string::npos);
  }

  SECTION("bad keys in tuples, deletes and writes") {
    for (const std::string& key :
         std::vector<std::string>{"", "a..b", "a.*", "*", ".a", "a.", "a b", "a=b",
                                  std::string(kMaxKeyBytes + 1, 'k'), std::string("a\0b", 3)}) {
      INFO("key '" << key << "'");
      auto t = sampleTuple();
      t.key = key;
      CHECK(rejectFrame(frameOf(RoutedMessage{env, TupleUpdate{1, t}})).find("bad tuple key") !=
            std::string::npos);
      CHECK(rejectFrame(frameOf(RoutedMessage{env, Write{1, WriteOp::Set, {}, 0, t}}))
                .find("bad tuple key") != std::string::npos);
      CHECK(rejectFrame(frameOf(RoutedMessage{env, TupleDeleted{1, 7, key, 1}})).find("bad key") !=
            std::string::npos);
    }
  }

  SECTION("bad key patterns") {
    for (const std::string& pattern :
         std::vector<std::string>{"", "a.**.b", "**.a", "a..b", "a.b*", "***"}) {
      INFO("pattern '" << pattern << "'");
      CHECK(rejectFrame(frameOf(RoutedMessage{env, Subscribe{1, 6000, {}, pattern}}))
                .find("bad key pattern") != std::string::npos);
    }
    CHECK(decode(bodyOf(frameOf(RoutedMessage{env, Subscribe{1, 6000, {}, "*.**"}})), kLimit)
              .message);
  }

  SECTION("invalid PEIS ids") {
    for (PeisId bad : {0, -1, -2147483647 - 1}) {
      INFO("id " << bad);
      auto t = sampleTuple();
      t.owner = bad;
      CHECK(rejectFrame(frameOf(RoutedMessage{env, TupleUpdate{1, t}})).find("tuple owner") !=
            std::string::npos);
      CHECK(rejectFrame(frameOf(RoutedMessage{env, Write{1, WriteOp::Set, {}, 0, t}}))
                .find("tuple owner") != std::string::npos);
      t = sampleTuple();
      t.creator = bad;
      CHECK(rejectFrame(frameOf(RoutedMessage{env, TupleUpdate{1, t}})).find("tuple creator") !=
            std::string::npos);
      CHECK(rejectFrame(frameOf(RoutedMessage{Envelope{bad, 3, 32}, Unsubscribe{1}}))
                .find("source") != std::string::npos);
      CHECK(rejectFrame(frameOf(RoutedMessage{Envelope{3, bad, 32}, Unsubscribe{1}}))
                .find("destination") != std::string::npos);
      CHECK(rejectFrame(frameOf(RoutedMessage{env, Subscribe{1, 6000, bad, "a"}})).find("owner") !=
            std::string::npos);
      CHECK(rejectFrame(frameOf(RoutedMessage{env, TupleDeleted{1, bad, "a", 1}})).find("owner") !=
            std::string::npos);
      CHECK(rejectFrame(frameOf(LinkMessage{Routes{{{4, 1, 0, 1, 0, ""}, {bad, 1, 0, 1, 0, ""}}}}))
                .find("route id") != std::string::npos);
      auto h = sampleHello();
      h.id = bad;
      CHECK(rejectFrame(frameOf(LinkMessage{h})).find("PEIS id") != std::string::npos);
      CHECK(rejectFrame(frameOf(LinkMessage{IdTaken{bad, 1}})).find("taken id") !=
            std::string::npos);
    }
  }

  SECTION("unknown encoding, write op and flags") {
    auto t = sampleTuple();
    t.encoding = static_cast<Encoding>(2);
    CHECK(rejectFrame(frameOf(RoutedMessage{env, TupleUpdate{1, t}})).find("unknown encoding 2") !=
          std::string::npos);
    CHECK(rejectFrame(frameOf(RoutedMessage{env, Write{1, WriteOp::Set, {}, 0, t}}))
              .find("unknown encoding 2") != std::string::npos);

    CHECK(rejectFrame(
              frameOf(RoutedMessage{env, Write{1, static_cast<WriteOp>(3), {}, 0, sampleTuple()}}))
              .find("unknown write op 3") != std::string::npos);

    // Write: type | envelope (9) | request (8) | op | has if-seqno at 19.
    auto write = frameOf(RoutedMessage{env, Write{1, WriteOp::Set, 5u, 0, sampleTuple()}});
    REQUIRE(write[kFrameHeaderBytes + 19] == 1);
    for (char flag : {'\x02', '\xff'}) {
      write[kFrameHeaderBytes + 19] = flag;
      CHECK(rejectFrame(write).find("if-seqno flag") != std::string::npos);
    }
    // Subscribe: type | envelope (9) | subscription (8) | lease (4) | has owner at 22.
    auto subscribe = frameOf(RoutedMessage{env, Subscribe{1, 6000, PeisId{7}, "a"}});
    REQUIRE(subscribe[kFrameHeaderBytes + 22] == 1);
    for (char flag : {'\x02', '\xff'}) {
      subscribe[kFrameHeaderBytes + 22] = flag;
      CHECK(rejectFrame(subscribe).find("owner flag") != std::string::npos);
    }
  }

  SECTION("negative write ttl") {
    for (std::int64_t ttl : {std::int64_t{-1}, std::numeric_limits<std::int64_t>::min()}) {
      CHECK(rejectFrame(frameOf(RoutedMessage{env, Write{1, WriteOp::Set, {}, ttl, sampleTuple()}}))
                .find("negative ttl") != std::string::npos);
    }
  }

  SECTION("Hello: bad magic, empty ecology, bad name") {
    auto frame = frameOf(LinkMessage{sampleHello()});
    REQUIRE(frame.substr(kFrameHeaderBytes + 1, 4) == "PEIS");
    frame[kFrameHeaderBytes + 4] = 'B';
    CHECK(rejectFrame(frame) == "bad magic");

    auto h = sampleHello();
    h.ecology = "";
    CHECK(rejectFrame(frameOf(LinkMessage{h})).find("empty ecology") != std::string::npos);

    for (const std::string& name : std::vector<std::string>{"a.b", "123", "a b", "x*"}) {
      h = sampleHello();
      h.name = name;
      CHECK(rejectFrame(frameOf(LinkMessage{h})).find("bad PEIS name") != std::string::npos);
      CHECK(rejectFrame(frameOf(LinkMessage{Routes{{{4, 1, 0, 1, 0, name}}}}))
                .find("bad PEIS name") != std::string::npos);
    }
  }

  SECTION("every single-byte corruption is decoded or rejected, never a crash") {
    for (const auto& [name, frame] : sampleFrames()) {
      INFO(name);
      std::string body(bodyOf(frame));
      for (std::size_t i = 0; i < body.size(); ++i) {
        for (unsigned char value : {0x00, 0x01, 0x02, 0x7f, 0x80, 0xff}) {
          auto corrupted = body;
          corrupted[i] = static_cast<char>(value);
          const auto result = decode(corrupted, kLimit);
          CHECK(result.message.has_value() == result.error.empty());
        }
      }
    }
  }
}

TEST_CASE("wire: decodeRouted reads into a reused message exactly what decode() reads",
          "[unit][wire]") {
  // One message object for every frame, as a link's inbox reuses its slots:
  // nothing of an earlier (longer) body may leak into a later one.
  RoutedMessage reused;
  std::string error;
  auto longer = sampleTuple();
  longer.key = "a.much.longer.key.than.the.next.one";
  longer.data = std::string(900, 'd');
  longer.mimetype = "application/x-long-mimetype";
  REQUIRE(decodeRouted(bodyOf(frameOf(RoutedMessage{Envelope{1, 2, 3}, TupleUpdate{5, longer}})),
                       kLimit, reused, error));
  for (const auto& [name, frame] : sampleFrames()) {
    INFO(name);
    const auto decoded = decode(bodyOf(frame), kLimit);
    REQUIRE(decoded.message);
    const auto* routed = std::get_if<RoutedMessage>(&*decoded.message);
    error.clear();
    if (!routed) {  // a link message is not for decodeRouted
      CHECK_FALSE(isRoutedFrame(bodyOf(frame)));
      CHECK_FALSE(decodeRouted(bodyOf(frame), kLimit, reused, error));
      CHECK_THAT(error, Catch::Contains("unknown routed message type"));
      continue;
    }
    CHECK(isRoutedFrame(bodyOf(frame)));
    REQUIRE(decodeRouted(bodyOf(frame), kLimit, reused, error));
    CHECK(reused == *routed);
    CHECK(error.empty());
  }
  SECTION("a malformed routed frame fails with decode()'s reason") {
    auto frame = frameOf(RoutedMessage{sampleEnvelope(), TupleUpdate{70, sampleTuple()}});
    frame.pop_back();  // one data byte short
    const auto reason = rejectFrame(frame);
    CHECK_FALSE(decodeRouted(bodyOf(frame), kLimit, reused, error));
    CHECK(error == reason);
    CHECK_FALSE(decodeRouted(std::string_view{}, kLimit, reused, error));
    CHECK(error == "empty frame");
  }
  SECTION("a bad key is rejected even right after a good key was read") {
    auto good = sampleTuple();
    REQUIRE(decodeRouted(bodyOf(frameOf(RoutedMessage{sampleEnvelope(), TupleUpdate{1, good}})),
                         kLimit, reused, error));
    REQUIRE(decodeRouted(bodyOf(frameOf(RoutedMessage{sampleEnvelope(), TupleUpdate{1, good}})),
                         kLimit, reused, error));
    auto bad = good;
    bad.key = "robot..x";
    CHECK_FALSE(decodeRouted(bodyOf(frameOf(RoutedMessage{sampleEnvelope(), TupleUpdate{1, bad}})),
                             kLimit, reused, error));
    CHECK_THAT(error, Catch::Contains("bad tuple key"));
  }
}

TEST_CASE("wire: decodeRouted rejects every malformed TupleUpdate with decode()'s reason",
          "[unit][wire]") {
  // The receive path reads a well-formed TupleUpdate with a few bounds
  // checks; whatever they refuse is read field by field for the reason.
  RoutedMessage reused;
  std::string error;
  const auto frame = frameOf(RoutedMessage{sampleEnvelope(), TupleUpdate{70, sampleTuple()}});
  const std::string body(bodyOf(frame));
  auto check = [&](const std::string& bytes, std::size_t limit = kLimit) {
    const auto decoded = decode(bytes, limit);
    error.clear();
    const bool ok = decodeRouted(bytes, limit, reused, error);
    CHECK(ok == decoded.message.has_value());
    CHECK(error == decoded.error);
    if (ok) CHECK(Message{reused} == *decoded.message);
  };
  SECTION("every length short of the frame, and one byte over") {
    for (std::size_t n = 1; n <= body.size(); ++n) {
      INFO(n);
      check(body.substr(0, n));
    }
    check(body + "x");
  }
  SECTION("every byte corrupted") {
    for (std::size_t i = 1; i < body.size(); ++i) {
      for (unsigned char value : {0x00, 0x01, 0x02, 0x2e, 0x7f, 0x80, 0xff}) {
        INFO(i << " " << int(value));
        auto corrupted = body;
        corrupted[i] = static_cast<char>(value);
        check(corrupted);
      }
    }
  }
  SECTION("data over the limit") { check(body, sampleTuple().data.size() - 1); }
}

TEST_CASE("wire: a stream's TupleUpdateEncoder writes encodeTupleUpdate's frames", "[unit][wire]") {
  TupleUpdateEncoder encoder;
  auto t = sampleTuple();
  auto same = [&](const Envelope& envelope, std::uint64_t incarnation) {
    std::string streamed = "xy", direct = "xy";
    encoder.append(envelope, incarnation, t, streamed);
    encodeTupleUpdate(envelope, incarnation, t, direct);
    CHECK(streamed == direct);
  };
  same(sampleEnvelope(), 70);
  t.seqno = 43;
  t.data = "a longer value than before";
  t.ts_write = at(5);
  same(sampleEnvelope(), 70);  // the repeated fields from the last frame
  t.key = "robot.position.y";  // every repeated field changed in turn
  same(sampleEnvelope(), 70);
  t.key = "robot.position.yz";
  same(sampleEnvelope(), 70);
  t.mimetype = "text/plain2";
  same(sampleEnvelope(), 70);
  t.mimetype = "";
  same(sampleEnvelope(), 70);
  t.creator = 9;
  same(sampleEnvelope(), 70);
  t.owner = 8;
  same(sampleEnvelope(), 70);
  t.encoding = Encoding::Binary;
  same(sampleEnvelope(), 70);
  same(sampleEnvelope(), 71);
  same(Envelope{7, 4, 17}, 71);
  same(Envelope{6, 4, 17}, 71);
  same(Envelope{6, 4, 16}, 71);
  t.data.clear();
  same(Envelope{6, 4, 16}, 71);
}

TEST_CASE("wire: a TupleUpdate encoded without its data, followed by the data, is the whole frame",
          "[unit][wire]") {
  auto t = sampleTuple();
  t.data = std::string(20000, 'z');
  std::string whole, head = "prefix";
  encodeTupleUpdate(sampleEnvelope(), 70, t, whole);
  encodeTupleUpdate(sampleEnvelope(), 70, t, head, TupleData::Omit);
  CHECK(head.size() == 6 + whole.size() - t.data.size());
  CHECK(head.substr(6) + t.data == whole);
  CHECK(whole.size() == tupleUpdateFrameBytes(t));
}

TEST_CASE("wire: the head of a big TupleUpdate says where its data goes", "[unit][wire]") {
  auto t = sampleTuple();
  t.data = std::string(900, 'd');
  const auto frame = frameOf(RoutedMessage{Envelope{7, 3, 30}, TupleUpdate{70, t}});
  const auto body = bodyOf(frame);
  const std::size_t headBytes = body.size() - t.data.size();
  RoutedMessage out;
  std::size_t dataAt = 0;

  SECTION("every field but the data, from the head alone or with some data") {
    for (const auto arrived : {headBytes, headBytes + 100, body.size() - 1}) {
      INFO(arrived);
      out.body = TupleUpdate{};
      std::get<TupleUpdate>(out.body).tuple.data = "left as it was";
      REQUIRE(decodeTupleUpdateHead(body.substr(0, arrived), body.size(), kLimit, out, dataAt));
      CHECK(dataAt == headBytes);
      CHECK(out.envelope == Envelope{7, 3, 30});
      auto decoded = std::get<TupleUpdate>(out.body);
      CHECK(decoded.ownerIncarnation == 70);
      CHECK(decoded.tuple.data == "left as it was");
      decoded.tuple.data = t.data;
      CHECK(decoded.tuple == t);
    }
  }
  SECTION("anything else is read whole (and decoded, or rejected, as any frame)") {
    // A head cut short, the whole frame, data over the limit, data that does
    // not end the frame, a bad key, another message type.
    CHECK_FALSE(
        decodeTupleUpdateHead(body.substr(0, headBytes - 1), body.size(), kLimit, out, dataAt));
    CHECK_FALSE(decodeTupleUpdateHead(body, body.size(), kLimit, out, dataAt));
    CHECK_FALSE(decodeTupleUpdateHead(body.substr(0, headBytes), body.size(), 899, out, dataAt));
    CHECK_FALSE(
        decodeTupleUpdateHead(body.substr(0, headBytes), body.size() + 1, kLimit, out, dataAt));
    auto bad = t;
    bad.key = "robot..x";
    const auto badFrame = frameOf(RoutedMessage{Envelope{7, 3, 30}, TupleUpdate{70, bad}});
    CHECK_FALSE(decodeTupleUpdateHead(bodyOf(badFrame).substr(0, headBytes), body.size(), kLimit,
                                      out, dataAt));
    const auto write =
        frameOf(RoutedMessage{Envelope{7, 3, 30}, Write{9, WriteOp::Set, std::nullopt, 0, t}});
    CHECK_FALSE(decodeTupleUpdateHead(bodyOf(write).substr(0, headBytes + 40), bodyOf(write).size(),
                                      kLimit, out, dataAt));
  }
}

TEST_CASE("wire: an oversized frame is read from its head and answered", "[unit][wire]") {
  constexpr std::size_t kSmall = 100;
  auto t = sampleTuple();
  t.data = std::string(5000, 'x');

  SECTION("a Write, for the owner and for a relay on the way") {
    const auto frame = frameOf(
        RoutedMessage{Envelope{9, 3, 30}, Write{77, WriteOp::Set, std::nullopt, 0, t, 5000}});
    const auto body = bodyOf(frame);
    CHECK_FALSE(decodeOversize(body, kLimit * 10));  // fits: not oversized
    // Its first kOversizeHeadBytes (or all of a shorter frame) are enough.
    const auto oversize = decodeOversize(body.substr(0, kOversizeHeadBytes), kSmall);
    REQUIRE(oversize);
    CHECK(oversize->type == MessageType::Write);
    CHECK(oversize->envelope == Envelope{9, 3, 30});
    CHECK(oversize->request == 77);
    CHECK(oversize->dataBytes == 5000);
    CHECK(oversize->tuple.key == t.key);
    CHECK(oversize->tuple.data.empty());

    const auto byOwner = answerOversize(*oversize, 3, kSmall);
    CHECK(byOwner.envelope.source == 3);
    CHECK(byOwner.envelope.destination == 9);
    const auto& result = std::get<WriteResult>(byOwner.body);
    CHECK(result.request == 77);
    CHECK(result.status == static_cast<int>(ErrorCode::TooLarge) + 1);
    CHECK(result.message ==
          "data is 5000 bytes; this PEIS accepts at most 100 (see --peis-max-data)");
    checkRoutedRoundTrip(byOwner);

    const auto byRelay = answerOversize(*oversize, 5, kSmall);
    CHECK(byRelay.envelope.source == 5);
    CHECK(byRelay.envelope.destination == 9);
    CHECK(std::get<WriteResult>(byRelay.body).message ==
          "data is 5000 bytes; PEIS 5 on the route to PEIS 3 accepts at most 100 (see "
          "--peis-max-data)");
  }

  SECTION("a TupleUpdate, for the subscriber and for a relay on the way") {
    const auto frame = frameOf(RoutedMessage{Envelope{7, 3, 30}, TupleUpdate{70, t}});
    const auto oversize = decodeOversize(bodyOf(frame).substr(0, kOversizeHeadBytes), kSmall);
    REQUIRE(oversize);
    CHECK(oversize->type == MessageType::TupleUpdate);
    CHECK(oversize->ownerIncarnation == 70);
    auto head = t;
    head.data.clear();
    CHECK(oversize->tuple == head);

    const auto here = answerOversize(*oversize, 3, kSmall);
    CHECK(here.envelope.source == 7);  // stands in for the owner's update
    CHECK(here.envelope.destination == 3);
    CHECK(std::get<TupleWithheld>(here.body) == TupleWithheld{70, 3, kSmall, 5000, head});

    const auto onTheWay = answerOversize(*oversize, 5, kSmall);
    CHECK(onTheWay.envelope.source == 5);
    CHECK(onTheWay.envelope.destination == 3);
    CHECK(std::get<TupleWithheld>(onTheWay.body) == TupleWithheld{70, 5, kSmall, 5000, head});
    checkRoutedRoundTrip(onTheWay);
  }

  SECTION("anything else is not an oversized frame") {
    CHECK_FALSE(decodeOversize({}, kSmall));
    CHECK_FALSE(decodeOversize(bodyOf(frameOf(LinkMessage{Ping{1}})), kSmall));
    CHECK_FALSE(decodeOversize(
        bodyOf(frameOf(RoutedMessage{sampleEnvelope(), Subscribe{1, 1, 7, "a"}})), kSmall));
    const auto frame = frameOf(RoutedMessage{Envelope{7, 3, 30}, TupleUpdate{70, t}});
    auto body = std::string(bodyOf(frame));
    // Every truncation before the data length: too short to answer.
    const auto headBytes = body.size() - t.data.size();
    for (std::size_t n = 0; n < headBytes; ++n) {
      INFO("truncated to " << n);
      CHECK_FALSE(decodeOversize(std::string_view(body).substr(0, n), kSmall));
    }
    body[4] = '\0';  // the source id, 7, becomes 0: invalid
    CHECK_FALSE(decodeOversize(body, kSmall));
  }
}

}  // namespace peis::wire
