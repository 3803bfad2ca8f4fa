// The Tiny PEIS-kernel: the tiny tuple and frame codec on bytes, malformed
// frames counted and dropped, the kernel model with a fake in-memory radio
// (kernels exchanging frames through test queues, the clock moved by hand),
// and the host-port device programs as separate processes on the simulated
// UDP medium.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <deque>
#include <memory>
#include <random>
#include <string>
#include <vector>

extern "C" {
#include "tiny_app.h"
#include "tiny_kernel.h"
#include "tiny_mac.h"
#include "tiny_serial.h"
#include "tiny_tuple.h"
}

#include "support/process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using Bytes = std::vector<uint8_t>;

namespace {

tiny_tuple makeTuple(uint16_t owner, std::vector<uint16_t> key, const std::string& data) {
  tiny_tuple t;
  std::memset(&t, 0, sizeof t);
  t.owner = owner;
  t.creator = owner;
  t.seqno = 1;
  tiny_key k{};
  k.len = static_cast<uint8_t>(key.size());
  for (size_t i = 0; i < key.size(); ++i) k.sub[i] = key[i];
  REQUIRE(tiny_tuple_set_key_data(&t, &k, data.data(), static_cast<uint8_t>(data.size())) == 0);
  return t;
}

Bytes encodeTuple(const tiny_tuple& t) {
  Bytes b(TINY_TUPLE_SIZE);
  size_t n = tiny_tuple_encode(&t, b.data(), b.size());
  b.resize(n);
  return b;
}

Bytes tupleFrame(uint16_t src, uint16_t dst, const tiny_tuple& t) {
  Bytes b(TINY_FRAME_MAX);
  b.resize(tiny_encode_tuple_frame(b.data(), src, dst, 7, &t));
  return b;
}

std::string dataOf(const tiny_tuple* t) {
  const uint8_t* d = tiny_tuple_data(t);
  return std::string(reinterpret_cast<const char*>(d), t->data_len);
}

// ---- a fake radio: every frame sent reaches every other node's queue ----
struct Bus;

struct Node {
  Bus* bus = nullptr;
  std::deque<Bytes> inbox;
  std::unique_ptr<tiny_kernel> k = std::make_unique<tiny_kernel>();
  bool asleep = false;         // neither polls nor hears
  uint32_t storedCounter = 0;  // its non-volatile memory (a secured radio)
  int counterWrites = 0;
};

struct Bus {
  uint32_t now = 1000;
  bool down = false;  // every frame is lost
  std::vector<std::unique_ptr<Node>> nodes;
  std::vector<Bytes> sent;  // every frame put on the air

  static int send(void* ctx, const uint8_t* frame, uint8_t len) {
    auto* self = static_cast<Node*>(ctx);
    Bytes f(frame, frame + len);
    self->bus->sent.push_back(f);
    if (self->bus->down) return 0;
    for (auto& n : self->bus->nodes)
      if (n.get() != self && !n->asleep) n->inbox.push_back(f);
    return 0;
  }
  static int recv(void* ctx, uint8_t* buf, uint8_t cap) {
    auto* self = static_cast<Node*>(ctx);
    if (self->inbox.empty()) return 0;
    Bytes f = std::move(self->inbox.front());
    self->inbox.pop_front();
    std::memcpy(buf, f.data(), std::min<size_t>(f.size(), cap));
    return static_cast<int>(f.size());
  }
  static uint32_t clock(void* ctx) { return static_cast<Node*>(ctx)->bus->now; }
  static int load(void* ctx, uint32_t* value) {
    *value = static_cast<Node*>(ctx)->storedCounter;
    return 0;
  }
  static int store(void* ctx, uint32_t value) {
    auto* self = static_cast<Node*>(ctx);
    self->storedCounter = value;
    ++self->counterWrites;
    return 0;
  }

  tiny_kernel* add(uint16_t id) {
    auto n = std::make_unique<Node>();
    n->bus = this;
    tiny_hal hal{n.get(), &Bus::send, &Bus::recv, &Bus::clock, &Bus::load, &Bus::store, nullptr};
    tiny_init(n->k.get(), id, &hal);
    nodes.push_back(std::move(n));
    return nodes.back()->k.get();
  }
  // The node restarts: its RAM is gone, its non-volatile memory kept.
  void restart(tiny_kernel* k) {
    auto& n = node(k);
    const uint16_t id = k->id;
    tiny_hal hal{&n, &Bus::send, &Bus::recv, &Bus::clock, &Bus::load, &Bus::store, nullptr};
    tiny_init(k, id, &hal);
  }
  Node& node(tiny_kernel* k) {
    for (auto& n : nodes)
      if (n->k.get() == k) return *n;
    FAIL("no such node");
    return *nodes.front();
  }
  // Moves the clock by `ms` in steps of `step`, polling every awake node.
  void run(uint32_t ms, uint32_t step = 10) {
    for (uint32_t t = 0; t < ms; t += step) {
      now += step;
      for (auto& n : nodes)
        if (!n->asleep) tiny_poll(n->k.get(), now);
    }
  }
  size_t sentOfType(uint8_t type) const {
    size_t c = 0;
    for (auto& f : sent) c += (!f.empty() && f[0] == type) ? 1 : 0;
    return c;
  }
};

struct Seen {
  std::vector<Bytes> tuples;  // every tuple a callback got, encoded
  static void cb(tiny_kernel*, const tiny_tuple* t, void* user) {
    static_cast<Seen*>(user)->tuples.push_back(encodeTuple(*t));
  }
};

uint32_t drops(const tiny_stats& s) {
  return s.drop_truncated + s.drop_bad_length + s.drop_bad_version + s.drop_unknown_type +
         s.drop_too_many_subkeys + s.drop_bad_key + s.drop_data_too_long + s.drop_bad_src;
}

}  // namespace

// ---------------------------------------------------------------- codec

TEST_CASE("tiny: the plant's tuple <3, 43, 0> has the documented bytes", "[unit][tiny]") {
  tiny_tuple t = makeTuple(3, {43}, "0");
  t.seqno = 0x0A0B0C0D;
  t.ts_write = 0x01020304;
  t.ts_user = 0x11223344;
  t.ts_expire = 5000;
  const Bytes expected = {
      0x03, 0x00,              // owner 3
      0x03, 0x00,              // creator 3
      0x0D, 0x0C, 0x0B, 0x0A,  // seqno
      0x04, 0x03, 0x02, 0x01,  // ts_write
      0x44, 0x33, 0x22, 0x11,  // ts_user
      0x88, 0x13, 0x00, 0x00,  // ts_expire 5000
      0x01,                    // key_len: one sub-key
      0x01,                    // data_len: one byte
      0x2B, 0x00,              // sub-key 43
      0x30,                    // "0"
  };
  CHECK(encodeTuple(t) == expected);
  CHECK(tiny_tuple_wire_size(&t) == 25);

  Bytes frame = tupleFrame(3, 4, t);
  const Bytes header = {
      TINY_FRAME_TUPLE, TINY_PROTOCOL_VERSION, 0x03, 0x00, 0x04, 0x00, 0x07, 0x00};
  REQUIRE(frame.size() == header.size() + expected.size());
  CHECK(Bytes(frame.begin(), frame.begin() + 8) == header);
  CHECK(Bytes(frame.begin() + 8, frame.end()) == expected);

  tiny_frame f;
  tiny_stats s{};
  REQUIRE(tiny_decode_frame(frame.data(), frame.size(), &f, &s) == TINY_DECODE_OK);
  CHECK(f.type == TINY_FRAME_TUPLE);
  CHECK(f.src == 3);
  CHECK(f.dst == 4);
  CHECK(f.seq == 7);
  CHECK(encodeTuple(f.tuple) == expected);
  CHECK(tiny_tuple_subkey(&f.tuple, 0) == 43);
  CHECK(dataOf(&f.tuple) == "0");
  CHECK(s.frames_rx == 1);
  CHECK(s.frames_ok == 1);
}

TEST_CASE("tiny: tuples and frames round-trip at every size limit", "[unit][tiny]") {
  SECTION("one sub-key and 68 bytes of data: a 92-byte tuple in a 100-byte frame") {
    tiny_tuple t = makeTuple(6890, {42}, std::string(68, 'x'));
    Bytes frame = tupleFrame(6890, TINY_ID_BROADCAST, t);
    CHECK(frame.size() == TINY_FRAME_MAX);
    tiny_frame f;
    REQUIRE(tiny_decode_frame(frame.data(), frame.size(), &f, nullptr) == TINY_DECODE_OK);
    CHECK(encodeTuple(f.tuple) == encodeTuple(t));
    CHECK(std::memcmp(&f.tuple, &t, sizeof t) == 0);
  }
  SECTION("seven sub-keys and 56 bytes of data") {
    tiny_tuple t = makeTuple(1, {1, 2, 3, 4, 5, 6, 0xFFFF}, std::string(56, '\x7f'));
    t.seqno = 0xFFFFFFFF;
    Bytes frame = tupleFrame(1, 2, t);
    CHECK(frame.size() == TINY_FRAME_MAX);
    tiny_frame f;
    REQUIRE(tiny_decode_frame(frame.data(), frame.size(), &f, nullptr) == TINY_DECODE_OK);
    CHECK(std::memcmp(&f.tuple, &t, sizeof t) == 0);
    tiny_key k;
    tiny_tuple_key(&f.tuple, &k);
    CHECK(k.len == 7);
    CHECK(k.sub[6] == 0xFFFF);
  }
  SECTION("empty data") {
    tiny_tuple t = makeTuple(9, {5}, "");
    Bytes frame = tupleFrame(9, 2, t);
    CHECK(frame.size() == 8 + 22 + 2);
    tiny_frame f;
    REQUIRE(tiny_decode_frame(frame.data(), frame.size(), &f, nullptr) == TINY_DECODE_OK);
    CHECK(f.tuple.data_len == 0);
  }
  SECTION("key and data that do not fit are refused by the encoder") {
    tiny_tuple t;
    tiny_key k{};
    k.len = 7;
    std::string data(57, 'a');  // 14 + 57 > 70
    CHECK(tiny_tuple_set_key_data(&t, &k, data.data(), 57) == -1);
    k.len = 8;
    CHECK(tiny_tuple_set_key_data(&t, &k, data.data(), 1) == -1);
    k.len = 0;
    CHECK(tiny_tuple_set_key_data(&t, &k, data.data(), 1) == -1);
  }
  SECTION("subscribe, unsubscribe and beacon frames") {
    uint8_t buf[TINY_FRAME_MAX];
    tiny_key k{};
    k.len = 2;
    k.sub[0] = 10;
    k.sub[1] = 0x1234;
    size_t n = tiny_encode_sub_frame(buf, TINY_FRAME_SUBSCRIBE, 4, 3, 9, 3, 0, &k);
    const Bytes expected = {2, 1, 4, 0, 3, 0, 9, 0, 3, 0, 0, 2, 10, 0, 0x34, 0x12};
    CHECK(Bytes(buf, buf + n) == expected);
    tiny_frame f;
    REQUIRE(tiny_decode_frame(buf, n, &f, nullptr) == TINY_DECODE_OK);
    CHECK(f.sub_owner == 3);
    CHECK(f.sub_flags == 0);
    CHECK(tiny_key_equal(&f.sub_key, &k));

    tiny_key none{};
    n = tiny_encode_sub_frame(buf, TINY_FRAME_UNSUBSCRIBE, 4, TINY_ID_BROADCAST, 1, TINY_ANY_OWNER,
                              TINY_SUB_PREFIX, &none);
    CHECK(n == 12);
    REQUIRE(tiny_decode_frame(buf, n, &f, nullptr) == TINY_DECODE_OK);
    CHECK(f.type == TINY_FRAME_UNSUBSCRIBE);
    CHECK(f.sub_owner == TINY_ANY_OWNER);
    CHECK(f.sub_key.len == 0);

    n = tiny_encode_beacon_frame(buf, 3, 2, TINY_BEACON_TINY, 1, 0x00010203);
    const Bytes beacon = {4, 1, 3, 0, 0xFF, 0xFF, 2, 0, 1, 1, 3, 2, 1, 0};
    CHECK(Bytes(buf, buf + n) == beacon);
    REQUIRE(tiny_decode_frame(buf, n, &f, nullptr) == TINY_DECODE_OK);
    CHECK(f.beacon_uptime_ms == 0x00010203);
    CHECK(f.beacon_tuples == 1);
  }
}

TEST_CASE("tiny: every class of malformed frame is dropped and counted", "[unit][tiny]") {
  const Bytes good = tupleFrame(3, 4, makeTuple(3, {43}, "0"));
  tiny_stats s{};
  tiny_frame f;
  auto decode = [&](const Bytes& b) { return tiny_decode_frame(b.data(), b.size(), &f, &s); };

  SECTION("truncated: shorter than the frame header, or than the tuple it declares") {
    CHECK(decode(Bytes(good.begin(), good.begin() + 5)) == TINY_DECODE_TRUNCATED);
    CHECK(decode(Bytes(good.begin(), good.begin() + 8 + 21)) == TINY_DECODE_TRUNCATED);
    CHECK(decode(Bytes(good.begin(), good.end() - 1)) == TINY_DECODE_TRUNCATED);
    CHECK(decode(Bytes{}) == TINY_DECODE_TRUNCATED);
    CHECK(s.drop_truncated == 4);
  }
  SECTION("wrong length: bytes after the tuple, or over 100 bytes") {
    Bytes longer = good;
    longer.push_back(0);
    CHECK(decode(longer) == TINY_DECODE_BAD_LENGTH);
    Bytes huge(101, 0);
    huge[0] = TINY_FRAME_TUPLE;
    huge[1] = TINY_PROTOCOL_VERSION;
    CHECK(decode(huge) == TINY_DECODE_BAD_LENGTH);
    uint8_t buf[TINY_FRAME_MAX];
    size_t n = tiny_encode_beacon_frame(buf, 3, 0, 0, 0, 0);
    Bytes beacon(buf, buf + n);
    beacon.push_back(1);
    CHECK(decode(beacon) == TINY_DECODE_BAD_LENGTH);
    CHECK(s.drop_bad_length == 3);
  }
  SECTION("unknown type and foreign version") {
    Bytes b = good;
    b[0] = 0;
    CHECK(decode(b) == TINY_DECODE_UNKNOWN_TYPE);
    b[0] = 99;
    CHECK(decode(b) == TINY_DECODE_UNKNOWN_TYPE);
    b = good;
    b[1] = 3;  // 1 is open, 2 secured (its trailer checked before decoding)
    CHECK(decode(b) == TINY_DECODE_BAD_VERSION);
    CHECK(s.drop_unknown_type == 2);
    CHECK(s.drop_bad_version == 1);
  }
  SECTION("too many sub-keys, in a tuple and in a subscription") {
    Bytes b = good;
    b[8 + TINY_OFF_KEY_LEN] = 8;
    CHECK(decode(b) == TINY_DECODE_TOO_MANY_SUBKEYS);
    b[8 + TINY_OFF_KEY_LEN] = 255;
    CHECK(decode(b) == TINY_DECODE_TOO_MANY_SUBKEYS);
    Bytes sub = {TINY_FRAME_SUBSCRIBE, 1, 4, 0, 3, 0, 0, 0, 3, 0, 0, 8};
    sub.resize(sub.size() + 16, 0);
    CHECK(decode(sub) == TINY_DECODE_TOO_MANY_SUBKEYS);
    CHECK(s.drop_too_many_subkeys == 3);
  }
  SECTION("data longer than 68 bytes, or key and data over the 70-byte storage") {
    Bytes b = good;
    b[8 + TINY_OFF_DATA_LEN] = 69;
    b.resize(8 + 22 + 2 + 69 > 100 ? 100 : 8 + 22 + 2 + 69, 0);
    CHECK(decode(b) == TINY_DECODE_DATA_TOO_LONG);
    b = good;
    b[8 + TINY_OFF_KEY_LEN] = 7;
    b[8 + TINY_OFF_DATA_LEN] = 57;
    CHECK(decode(b) == TINY_DECODE_DATA_TOO_LONG);
    CHECK(s.drop_data_too_long == 2);
  }
  SECTION("a tuple without a key, bad subscription flags, a sender that is no node") {
    Bytes b = good;
    b[8 + TINY_OFF_KEY_LEN] = 0;
    CHECK(decode(b) == TINY_DECODE_BAD_KEY);
    Bytes sub = {TINY_FRAME_SUBSCRIBE, 1, 4, 0, 3, 0, 0, 0, 3, 0, 0x80, 1, 43, 0};
    CHECK(decode(sub) == TINY_DECODE_BAD_KEY);
    Bytes exact = {TINY_FRAME_SUBSCRIBE, 1, 4, 0, 3, 0, 0, 0, 3, 0, 0, 0};  // no key, no prefix
    CHECK(decode(exact) == TINY_DECODE_BAD_KEY);
    b = good;
    b[2] = 0xFF;
    b[3] = 0xFF;
    CHECK(decode(b) == TINY_DECODE_BAD_SRC);
    CHECK(s.drop_bad_key == 3);
    CHECK(s.drop_bad_src == 1);
  }
  CHECK(s.frames_ok == 0);
  CHECK(drops(s) == s.frames_rx);
}

TEST_CASE("tiny: the decoder survives random and mutated bytes, counting each frame once",
          "[unit][tiny]") {
  std::mt19937 rng(42);
  tiny_stats s{};
  tiny_frame f;
  const Bytes good = tupleFrame(3, 4, makeTuple(3, {43, 1}, "hello"));
  for (int i = 0; i < 200000; ++i) {
    Bytes b;
    if (i % 2 == 0) {
      b.resize(rng() % 120);
      for (auto& x : b) x = static_cast<uint8_t>(rng());
      if (!b.empty() && i % 4 == 0) b[0] = static_cast<uint8_t>(1 + rng() % 4);
      if (b.size() > 1 && i % 4 == 0) b[1] = TINY_PROTOCOL_VERSION;
    } else {
      b = good;
      b[rng() % b.size()] = static_cast<uint8_t>(rng());
      if (rng() % 3 == 0) b.resize(rng() % (b.size() + 1));
    }
    tiny_decode_result r = tiny_decode_frame(b.data(), b.size(), &f, &s);
    if (r == TINY_DECODE_OK && f.type == TINY_FRAME_TUPLE) {
      REQUIRE(f.tuple.key_len >= 1);
      REQUIRE(f.tuple.key_len <= TINY_MAX_SUBKEYS);
      REQUIRE(tiny_tuple_wire_size(&f.tuple) + 8 == b.size());
    }
  }
  CHECK(s.frames_rx == 200000);
  CHECK(s.frames_ok + drops(s) == s.frames_rx);
  CHECK(s.frames_ok > 0);
}

// --------------------------------------------------------------- kernel

TEST_CASE(
    "tiny: Plant posts <3, 43, 0> and Blind, subscribed to key 43 of PEIS 3, gets it "
    "byte for byte",
    "[unit][tiny]") {
  Bus bus;
  tiny_kernel* plant = bus.add(3);
  tiny_kernel* blind = bus.add(4);
  Seen seen;
  tiny_key tilt = tiny_key1(TINY_KEY_TILT_VALUE);
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, &Seen::cb, &seen) >= 0);
  bus.run(50);
  CHECK(tiny_subscriber_count(plant) == 1);
  CHECK(tiny_neighbor_count(plant) == 1);
  CHECK(tiny_neighbor_count(blind) == 1);

  REQUIRE(tiny_set(plant, &tilt, "0", 1) == TINY_OK);
  bus.run(50);
  const tiny_tuple* own = tiny_get(plant, 3, &tilt);
  REQUIRE(own != nullptr);
  REQUIRE(seen.tuples.size() == 1);
  CHECK(seen.tuples[0] == encodeTuple(*own));
  const tiny_tuple* cached = tiny_get(blind, 3, &tilt);
  REQUIRE(cached != nullptr);
  CHECK(std::memcmp(cached, own, sizeof(tiny_tuple)) == 0);
  CHECK(cached->owner == 3);
  CHECK(cached->seqno == 1);
  CHECK(dataOf(cached) == "0");

  // Renewals re-send the value; duplicates are stale, callbacks run once.
  bus.run(3000);
  CHECK(seen.tuples.size() == 1);
  CHECK(tiny_get_stats(blind)->tuples_stale > 0);

  // A new value is delivered with the next seqno.
  REQUIRE(tiny_set(plant, &tilt, "100", 3) == TINY_OK);
  bus.run(20);
  REQUIRE(seen.tuples.size() == 2);
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "100");
  CHECK(tiny_get(blind, 3, &tilt)->seqno == 2);
  CHECK(drops(*tiny_get_stats(blind)) == 0);
}

TEST_CASE("tiny: a subscription made after the write gets the current value", "[unit][tiny]") {
  Bus bus;
  tiny_kernel* plant = bus.add(3);
  tiny_kernel* blind = bus.add(4);
  tiny_key tilt = tiny_key1(43);
  REQUIRE(tiny_set(plant, &tilt, "0", 1) == TINY_OK);
  bus.run(100);
  CHECK(bus.sentOfType(TINY_FRAME_TUPLE) == 0);  // nobody asked yet
  Seen seen;
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, &Seen::cb, &seen) >= 0);
  bus.run(20);
  REQUIRE(seen.tuples.size() == 1);
  CHECK(seen.tuples[0] == encodeTuple(*tiny_get(plant, 3, &tilt)));
}

TEST_CASE("tiny: wildcard subscriptions: any owner, key prefixes", "[unit][tiny]") {
  Bus bus;
  tiny_kernel* a = bus.add(3);
  tiny_kernel* b = bus.add(5);
  tiny_kernel* watcher = bus.add(9);
  tiny_key k10_1{}, k10_2{}, k11{}, prefix{}, none{};
  k10_1.len = 2, k10_1.sub[0] = 10, k10_1.sub[1] = 1;
  k10_2.len = 2, k10_2.sub[0] = 10, k10_2.sub[1] = 2;
  k11 = tiny_key1(11);
  prefix = tiny_key1(10);
  Seen byPrefix, everything, exactAny;
  REQUIRE(tiny_subscribe(watcher, TINY_ANY_OWNER, &prefix, TINY_SUB_PREFIX, &Seen::cb, &byPrefix) >=
          0);
  REQUIRE(tiny_subscribe(watcher, TINY_ANY_OWNER, &none, TINY_SUB_PREFIX, &Seen::cb, &everything) >=
          0);
  REQUIRE(tiny_subscribe(watcher, TINY_ANY_OWNER, &k11, 0, &Seen::cb, &exactAny) >= 0);
  tiny_key empty{};
  CHECK(tiny_subscribe(watcher, 3, &empty, 0, nullptr, nullptr) == TINY_ERR_ARG);
  bus.run(50);
  CHECK(tiny_subscriber_count(a) == 3);
  CHECK(tiny_subscriber_count(b) == 3);

  REQUIRE(tiny_set(a, &k10_1, "a", 1) == TINY_OK);
  REQUIRE(tiny_set(b, &k10_2, "b", 1) == TINY_OK);
  REQUIRE(tiny_set(a, &k11, "c", 1) == TINY_OK);
  REQUIRE(tiny_set(b, &prefix, "d", 1) == TINY_OK);  // key {10} itself matches prefix {10}
  bus.run(50);
  CHECK(byPrefix.tuples.size() == 3);
  CHECK(everything.tuples.size() == 4);
  REQUIRE(exactAny.tuples.size() == 1);
  CHECK(exactAny.tuples[0] == encodeTuple(*tiny_get(a, 3, &k11)));
  REQUIRE(tiny_get(watcher, 5, &k10_2) != nullptr);
  CHECK(dataOf(tiny_get(watcher, 5, &k10_2)) == "b");
}

TEST_CASE("tiny: subscriptions are re-sent, so lost subscriptions and values recover",
          "[unit][tiny]") {
  Bus bus;
  tiny_kernel* plant = bus.add(3);
  tiny_kernel* blind = bus.add(4);
  tiny_key tilt = tiny_key1(43);
  Seen seen;
  bus.down = true;  // the first subscription is lost
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, &Seen::cb, &seen) >= 0);
  REQUIRE(tiny_set(plant, &tilt, "0", 1) == TINY_OK);
  bus.run(100);
  CHECK(tiny_subscriber_count(plant) == 0);
  bus.down = false;
  const size_t before = bus.sentOfType(TINY_FRAME_SUBSCRIBE);
  bus.run(TINY_RESUB_INTERVAL_MS + 50);
  CHECK(bus.sentOfType(TINY_FRAME_SUBSCRIBE) > before);
  CHECK(tiny_subscriber_count(plant) == 1);
  REQUIRE(seen.tuples.size() == 1);

  // A value lost on the air arrives with the answer to the next renewal.
  bus.down = true;
  REQUIRE(tiny_set(plant, &tilt, "50", 2) == TINY_OK);
  bus.run(20);
  bus.down = false;
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "0");
  bus.run(TINY_RESUB_INTERVAL_MS + 50);
  REQUIRE(seen.tuples.size() == 2);
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "50");
}

TEST_CASE("tiny: subscribers that stop renewing are forgotten, unsubscribing is immediate",
          "[unit][tiny]") {
  Bus bus;
  tiny_kernel* plant = bus.add(3);
  tiny_kernel* blind = bus.add(4);
  tiny_key tilt = tiny_key1(43);
  int h = tiny_subscribe(blind, 3, &tilt, 0, nullptr, nullptr);
  REQUIRE(h >= 0);
  bus.run(50);
  REQUIRE(tiny_subscriber_count(plant) == 1);

  bus.node(blind).asleep = true;  // the blind goes silent
  bus.run(TINY_SUBSCRIBER_TIMEOUT_MS - 100);
  CHECK(tiny_subscriber_count(plant) == 1);
  bus.run(200);
  CHECK(tiny_subscriber_count(plant) == 0);
  bus.run(TINY_NEIGHBOR_TIMEOUT_MS);
  CHECK(tiny_neighbor_count(plant) == 0);
  // Nobody listens: a write sends nothing.
  const size_t tuples = bus.sentOfType(TINY_FRAME_TUPLE);
  REQUIRE(tiny_set(plant, &tilt, "0", 1) == TINY_OK);
  CHECK(bus.sentOfType(TINY_FRAME_TUPLE) == tuples);

  // It wakes up: the next renewal makes it a subscriber again.
  bus.node(blind).asleep = false;
  bus.run(TINY_RESUB_INTERVAL_MS + 50);
  CHECK(tiny_subscriber_count(plant) == 1);
  REQUIRE(tiny_get(blind, 3, &tilt) != nullptr);

  REQUIRE(tiny_unsubscribe(blind, h) == TINY_OK);
  bus.run(20);
  CHECK(tiny_subscriber_count(plant) == 0);
  CHECK(tiny_get(blind, 3, &tilt) == nullptr);  // no longer wanted, no longer cached
  CHECK(tiny_unsubscribe(blind, h) == TINY_ERR_ARG);
}

TEST_CASE("tiny: the static tables are bounded: store, cache, subscriptions", "[unit][tiny]") {
  Bus bus;
  tiny_kernel* node = bus.add(3);
  tiny_kernel* watcher = bus.add(9);
  for (uint16_t i = 0; i < TINY_MAX_TUPLES; ++i) {
    tiny_key k = tiny_key1(static_cast<uint16_t>(100 + i));
    REQUIRE(tiny_set(node, &k, "v", 1) == TINY_OK);
  }
  CHECK(tiny_own_count(node) == TINY_MAX_TUPLES);
  tiny_key extra = tiny_key1(999);
  CHECK(tiny_set(node, &extra, "v", 1) == TINY_ERR_FULL);
  CHECK(tiny_get(node, 3, &extra) == nullptr);
  tiny_key first = tiny_key1(100);
  CHECK(tiny_set(node, &first, "w", 1) == TINY_OK);  // updates always fit
  CHECK(tiny_get(node, 3, &first)->seqno == 2);
  CHECK(dataOf(tiny_get(node, 3, &first)) == "w");

  std::string tooLong(TINY_MAX_DATA + 1, 'x');
  CHECK(tiny_set(node, &first, tooLong.data(), static_cast<uint8_t>(tooLong.size())) ==
        TINY_ERR_ARG);
  tiny_key seven{};
  seven.len = 7;
  CHECK(tiny_set(node, &seven, tooLong.data(), 57) == TINY_ERR_ARG);

  // The watcher takes everything: the cache keeps what fits, counts the rest.
  tiny_key none{};
  REQUIRE(tiny_subscribe(watcher, TINY_ANY_OWNER, &none, TINY_SUB_PREFIX, nullptr, nullptr) >= 0);
  bus.run(50);
  CHECK(tiny_get_stats(watcher)->tuples_accepted == TINY_MAX_CACHE);
  CHECK(tiny_get_stats(watcher)->cache_full == TINY_MAX_TUPLES - TINY_MAX_CACHE);

  for (int i = 1; i < TINY_MAX_SUBS; ++i)
    REQUIRE(tiny_subscribe(watcher, 3, &first, 0, nullptr, nullptr) >= 0);
  CHECK(tiny_subscribe(watcher, 3, &first, 0, nullptr, nullptr) == TINY_ERR_FULL);
}

TEST_CASE("tiny: a WRITE frame sets the owner's tuple, which publishes it; others are refused",
          "[unit][tiny]") {
  Bus bus;
  tiny_kernel* owner = bus.add(3);
  tiny_kernel* watcher = bus.add(4);
  Seen seen;  // frames below are injected as if sent by node 9
  tiny_key tilt = tiny_key1(43);
  REQUIRE(tiny_subscribe(watcher, 3, &tilt, 0, &Seen::cb, &seen) >= 0);
  REQUIRE(tiny_subscribe(owner, 3, &tilt, 0, &Seen::cb, &seen) >= 0);  // its own callback
  bus.run(20);

  auto request = makeTuple(3, {43}, "55");
  request.creator = 9;
  Bytes frame(TINY_FRAME_MAX);
  frame.resize(tiny_encode_write_frame(frame.data(), 9, 1, &request));
  REQUIRE(frame.size() == TINY_FRAME_HEADER_SIZE + TINY_TUPLE_HEADER_SIZE + 2 + 2);
  CHECK(frame[0] == TINY_FRAME_WRITE);
  CHECK((frame[4] == 3 && frame[5] == 0));  // dst: the owner
  bus.node(owner).inbox.push_back(frame);
  bus.run(20);

  const tiny_tuple* now = tiny_get(owner, 3, &tilt);
  REQUIRE(now != nullptr);
  CHECK(dataOf(now) == "55");
  CHECK(now->creator == 9);  // the writer
  CHECK(now->seqno == 1);    // the owner's own numbering
  CHECK(tiny_get_stats(owner)->writes_accepted == 1);
  REQUIRE(tiny_get(watcher, 3, &tilt) != nullptr);  // published to the subscriber
  CHECK(dataOf(tiny_get(watcher, 3, &tilt)) == "55");
  CHECK(seen.tuples.size() == 2);  // the owner's callback and the watcher's

  // A write for another owner (addressed to us by mistake) is refused.
  auto foreign = makeTuple(5, {43}, "1");
  Bytes wrong(TINY_FRAME_MAX);
  wrong.resize(tiny_encode_write_frame(wrong.data(), 9, 2, &foreign));
  wrong[4] = 3;  // dst 3, owner 5
  bus.node(owner).inbox.push_back(wrong);
  // A new key when the store is full is refused too.
  for (uint16_t i = 0; tiny_own_count(owner) < TINY_MAX_TUPLES; ++i) {
    tiny_key k = tiny_key1(static_cast<uint16_t>(100 + i));
    REQUIRE(tiny_set(owner, &k, "v", 1) == TINY_OK);
  }
  auto fresh = makeTuple(3, {999}, "1");
  Bytes full(TINY_FRAME_MAX);
  full.resize(tiny_encode_write_frame(full.data(), 9, 3, &fresh));
  bus.node(owner).inbox.push_back(full);
  bus.run(20);
  CHECK(tiny_get_stats(owner)->writes_refused == 2);
  CHECK(dataOf(tiny_get(owner, 3, &tilt)) == "55");
}

TEST_CASE("tiny: seqno ordering per (owner, key): old and repeated values are stale",
          "[unit][tiny]") {
  Bus bus;
  tiny_kernel* blind = bus.add(4);
  tiny_key tilt = tiny_key1(43);
  Seen seen;
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, &Seen::cb, &seen) >= 0);
  Node& n = bus.node(blind);
  tiny_tuple t = makeTuple(3, {43}, "5");
  t.seqno = 10;
  n.inbox.push_back(tupleFrame(3, 4, t));
  n.inbox.push_back(tupleFrame(3, 4, t));                                          // duplicate
  n.inbox.push_back(tupleFrame(3, TINY_ID_BROADCAST, makeTuple(3, {43}, "old")));  // seqno 1
  bus.run(10);
  REQUIRE(seen.tuples.size() == 1);
  CHECK(tiny_get_stats(blind)->tuples_stale == 2);
  t.seqno = 0xFFFFFFFF;  // 11 writes before 10 in serial-number order
  n.inbox.push_back(tupleFrame(3, 4, t));
  n.inbox.push_back(tupleFrame(3, 4, makeTuple(3, {43}, "x")));  // seqno 1: stale
  bus.run(10);
  CHECK(seen.tuples.size() == 1);
  tiny_tuple newer = makeTuple(3, {43}, "6");
  newer.seqno = 11;
  n.inbox.push_back(tupleFrame(3, 4, newer));
  // Another node's key 43 and a frame for someone else are not ours.
  tiny_tuple other = makeTuple(8, {43}, "7");
  n.inbox.push_back(tupleFrame(8, 4, other));
  n.inbox.push_back(tupleFrame(3, 5, newer));
  bus.run(10);
  REQUIRE(seen.tuples.size() == 2);
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "6");
  CHECK(tiny_get_stats(blind)->tuples_unwanted == 1);
  CHECK(tiny_get_stats(blind)->not_for_me == 1);
}

TEST_CASE("tiny: a restarted owner (its beacon's uptime went back) starts its seqnos again",
          "[unit][tiny]") {
  Bus bus;
  tiny_kernel* blind = bus.add(4);
  tiny_key tilt = tiny_key1(43);
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, nullptr, nullptr) >= 0);
  Node& n = bus.node(blind);
  uint8_t buf[TINY_FRAME_MAX];
  auto beacon = [&](uint32_t uptime) {
    size_t len = tiny_encode_beacon_frame(buf, 3, 0, TINY_BEACON_TINY, 1, uptime);
    n.inbox.push_back(Bytes(buf, buf + len));
  };
  tiny_tuple t = makeTuple(3, {43}, "0");
  t.seqno = 40;
  beacon(60000);
  n.inbox.push_back(tupleFrame(3, 4, t));
  bus.run(10);
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "0");
  beacon(5);                                                       // restarted
  n.inbox.push_back(tupleFrame(3, 4, makeTuple(3, {43}, "100")));  // seqno 1
  bus.run(10);
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "100");
  CHECK(tiny_get_stats(blind)->tuples_stale == 0);
}

TEST_CASE("tiny: the kernel drops and counts malformed frames from the radio", "[unit][tiny]") {
  Bus bus;
  tiny_kernel* blind = bus.add(4);
  tiny_key tilt = tiny_key1(43);
  Seen seen;
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, &Seen::cb, &seen) >= 0);
  Node& n = bus.node(blind);
  Bytes good = tupleFrame(3, 4, makeTuple(3, {43}, "0"));
  Bytes cut(good.begin(), good.end() - 1);
  Bytes unknown = good;
  unknown[0] = 42;
  Bytes tooMany = good;
  tooMany[8 + TINY_OFF_KEY_LEN] = 9;
  Bytes tooLong = good;
  tooLong[8 + TINY_OFF_DATA_LEN] = 69;
  Bytes oversize(150, 0);  // the HAL hands over a frame longer than the buffer
  for (const Bytes* b : {&cut, &unknown, &tooMany, &tooLong, &oversize}) n.inbox.push_back(*b);
  n.inbox.push_back(good);
  bus.run(10);
  const tiny_stats& s = *tiny_get_stats(blind);
  CHECK(s.drop_truncated == 1);
  CHECK(s.drop_unknown_type == 1);
  CHECK(s.drop_too_many_subkeys == 1);
  CHECK(s.drop_data_too_long == 1);
  CHECK(s.drop_bad_length == 1);
  CHECK(seen.tuples.size() == 1);  // the good frame still gets through
}

TEST_CASE("tiny: tuples with a lifetime expire", "[unit][tiny]") {
  Bus bus;
  tiny_kernel* plant = bus.add(3);
  tiny_kernel* blind = bus.add(4);
  tiny_key tilt = tiny_key1(43);
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, nullptr, nullptr) >= 0);
  bus.run(20);
  REQUIRE(tiny_set_ex(plant, &tilt, "0", 1, 77, 500) == TINY_OK);
  bus.run(20);
  REQUIRE(tiny_get(blind, 3, &tilt) != nullptr);
  CHECK(tiny_get(blind, 3, &tilt)->ts_user == 77);
  CHECK(tiny_get(blind, 3, &tilt)->ts_expire == 500);
  bus.run(500);
  CHECK(tiny_get(plant, 3, &tilt) == nullptr);
  CHECK(tiny_get(blind, 3, &tilt) == nullptr);
}

TEST_CASE("tiny: decimal helpers of the device programs", "[unit][tiny]") {
  char buf[12];
  CHECK(std::string(buf, tiny_format_long(0, buf, sizeof buf)) == "0");
  CHECK(std::string(buf, tiny_format_long(-1250, buf, sizeof buf)) == "-1250");
  long v = 0;
  CHECK(tiny_parse_long(reinterpret_cast<const uint8_t*>("100"), 3, &v) == 0);
  CHECK(v == 100);
  CHECK(tiny_parse_long(reinterpret_cast<const uint8_t*>("1x"), 2, &v) != 0);
  CHECK(tiny_parse_long(reinterpret_cast<const uint8_t*>("-"), 1, &v) != 0);
  CHECK(tiny_parse_long(nullptr, 0, &v) != 0);
}

// ---------------------------------------------------------- integration

namespace {
// A medium of its own per test run: 16 UDP ports on 127.0.0.1.
unsigned mediumPort(unsigned salt) {
  return 20000u + ((static_cast<unsigned>(getpid()) * 7u + salt) % 600u) * 16u;
}
}  // namespace

TEST_CASE("tiny: plant and blind processes on the simulated UDP medium: the blind closes",
          "[integration][tiny]") {
  using peis::test::Process;
  using peis::test::waitFor;
  struct Medium {
    const char* name;
    Process::Environment env;
  };
  const std::vector<Medium> media = {
      {"clean", {}},
      {"lossy",
       {{"TINY_LOSS", "30"},
        {"TINY_DUP", "20"},
        {"TINY_DELAY_MS", "10"},
        {"TINY_JITTER_MS", "40"}}},
  };
  unsigned salt = 0;
  for (const auto& medium : media) {
    DYNAMIC_SECTION("medium " << medium.name) {
      Process::Environment env = medium.env;
      env.emplace_back("TINY_MEDIUM_PORT", std::to_string(mediumPort(salt)));
      env.emplace_back("TINY_MEDIUM_SLOTS", "16");
      env.emplace_back("TINY_LIGHT", "900");  // too much sun for the plant
      Process blind({TINY_BLIND_PATH}, env);
      Process plant({TINY_PLANT_PATH}, env);
      // The plant prints its request after writing it, so the blind may
      // report first: wait for both lines.
      const bool closed = waitFor(
          [&] {
            return blind.out().find("blind closed 0\n") != std::string::npos &&
                   plant.out().find("plant tilt 0\n") != std::string::npos;
          },
          20s);
      INFO(blind.describe());
      INFO(plant.describe());
      REQUIRE(closed);
      blind.kill(SIGTERM);
      plant.kill(SIGTERM);
      CHECK(blind.wait(5s) == std::optional<int>(0));
      CHECK(plant.wait(5s) == std::optional<int>(0));
      // The kernel counters at exit: nothing malformed crossed the medium.
      CHECK(blind.err().find("truncated 0 bad-length 0 bad-version 0 unknown-type 0") !=
            std::string::npos);
    }
    ++salt;
  }
}

TEST_CASE("tiny: a node whose radio link is cut hears nothing until the cut ends",
          "[integration][tiny]") {
  using peis::test::Process;
  using peis::test::waitFor;
  peis::test::TempDir dir("radio-cut");
  const std::string cut = dir.write("blind.cut", "cut\n");
  const std::string port = std::to_string(mediumPort(7));
  Process::Environment common{{"TINY_MEDIUM_PORT", port}, {"TINY_MEDIUM_SLOTS", "16"}};
  Process::Environment blindEnv = common;
  blindEnv.emplace_back("TINY_RADIO_CUT_FILE", cut);
  Process::Environment plantEnv = common;
  plantEnv.emplace_back("TINY_LIGHT", "900");  // too much sun: the plant asks the blind to close
  Process blind({TINY_BLIND_PATH}, blindEnv);
  Process plant({TINY_PLANT_PATH}, plantEnv);
  REQUIRE(waitFor([&] { return plant.out().find("plant tilt 0\n") != std::string::npos; }, 20s));
  // The plant re-sends its tuple to the blind's renewed subscription within a
  // few seconds; with the link cut, none of it arrives.
  CHECK_FALSE(waitFor([&] { return blind.out().find("blind closed") != std::string::npos; }, 4s));
  std::remove(cut.c_str());
  const bool closed =
      waitFor([&] { return blind.out().find("blind closed 0\n") != std::string::npos; }, 20s);
  INFO(blind.describe());
  REQUIRE(closed);
  blind.kill(SIGTERM);
  REQUIRE(blind.wait(5s) == std::optional<int>(0));
  // What the cut swallowed is counted.
  const std::string err = blind.err();
  const auto at = err.find(" cut ");
  REQUIRE(at != std::string::npos);
  CHECK(std::stol(err.substr(at + 5)) > 0);
}

TEST_CASE("tiny: serial framing (0x7E, length, frame, checksum) round-trips and resyncs",
          "[unit][tiny]") {
  const uint8_t frame[] = {0x01, 0x01, 0x03, 0x00, 0x7E, 0xFF, 0x00, 0x00};
  uint8_t wire[TINY_SERIAL_MAX];
  const uint8_t n = tiny_serial_encode(wire, frame, sizeof frame);
  REQUIRE(n == sizeof frame + 3);
  CHECK(wire[0] == 0x7E);
  CHECK(wire[1] == sizeof frame);
  unsigned sum = 0;
  for (uint8_t i = 0; i < sizeof frame; ++i) sum += frame[i];
  CHECK(static_cast<uint8_t>(sum + wire[n - 1]) == 0xFF);  // XBee-style checksum
  CHECK(tiny_serial_encode(wire, frame, 0) == 0);
  CHECK(tiny_serial_encode(wire, frame, TINY_FRAME_MAX + 1) == 0);

  tiny_serial_rx rx;
  tiny_serial_rx_init(&rx);
  // Noise, a bad length, a frame with a bad checksum, then a good frame.
  Bytes stream = {0x00, 0x55, 0x7E, 0x00, 0x7E, 101};
  Bytes bad(wire, wire + n);
  bad[n - 1] ^= 0x01;
  stream.insert(stream.end(), bad.begin(), bad.end());
  stream.insert(stream.end(), wire, wire + n);
  int frames = 0;
  for (uint8_t b : stream) {
    const uint8_t got = tiny_serial_rx_byte(&rx, b);
    if (got != 0) {
      ++frames;
      REQUIRE(got == sizeof frame);
      CHECK(std::memcmp(rx.buf, frame, got) == 0);
    }
  }
  CHECK(frames == 1);
  CHECK(rx.bad_length == 2);
  CHECK(rx.bad_checksum == 1);
}

namespace {
std::vector<uint8_t> sentBytes;
void collectByte(uint8_t byte) { sentBytes.push_back(byte); }
}  // namespace

TEST_CASE("tiny: the UART helpers frame what they send and decode a ring that wraps",
          "[unit][tiny]") {
  const uint8_t frame[] = {1, 2, 3, 0x7E, 5};
  sentBytes.clear();
  REQUIRE(tiny_serial_send(collectByte, frame, sizeof frame) == 0);
  uint8_t encoded[TINY_SERIAL_MAX];
  const auto n = tiny_serial_encode(encoded, frame, sizeof frame);
  CHECK(sentBytes == std::vector<uint8_t>(encoded, encoded + n));
  CHECK(tiny_serial_send(collectByte, frame, 0) == -1);

  // A 16-byte ring filled by the "interrupt" and drained by the main loop;
  // 8-byte encoded frames, so the second one wraps around the end.
  volatile uint8_t bytes[16];
  tiny_serial_ring ring = {bytes, 15, 0, 0, 0};
  tiny_serial_rx rx;
  tiny_serial_rx_init(&rx);
  uint8_t out[TINY_FRAME_MAX];
  for (int round = 0; round < 3; ++round) {
    INFO("round " << round);
    for (std::size_t i = 0; i < n; ++i) tiny_serial_ring_put(&ring, encoded[i]);
    CHECK(tiny_serial_ring_recv(&ring, &rx, out, sizeof out) == sizeof frame);
    CHECK(std::memcmp(out, frame, sizeof frame) == 0);
    CHECK(tiny_serial_ring_recv(&ring, &rx, out, sizeof out) == 0);
  }
  CHECK(ring.overruns == 0);

  // A full ring drops and counts; a frame longer than the caller's buffer is
  // reported with its real length (the kernel drops and counts it).
  for (int i = 0; i < 20; ++i) tiny_serial_ring_put(&ring, 0x00);
  CHECK(ring.overruns == 5);  // 15 usable slots of 16
  CHECK(tiny_serial_ring_recv(&ring, &rx, out, sizeof out) == 0);
  for (std::size_t i = 0; i < n; ++i) tiny_serial_ring_put(&ring, encoded[i]);
  CHECK(tiny_serial_ring_recv(&ring, &rx, out, 2) == sizeof frame);
  CHECK(out[0] == 1);
  CHECK(out[1] == 2);
}

// ---- a secured radio (docs/security.md) ---------------------------------------

namespace {

const uint8_t kKeyA[TINY_MAC_KEY_SIZE] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16};
const uint8_t kKeyB[TINY_MAC_KEY_SIZE] = {21, 22, 23, 24, 25, 26, 27, 28,
                                          29, 30, 31, 32, 33, 34, 35, 36};
const uint8_t kKeyBridge[TINY_MAC_KEY_SIZE] = {9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9};

std::string hexOf(const uint8_t* b, size_t n) {
  std::string out;
  char d[3];
  for (size_t i = 0; i < n; ++i) {
    std::snprintf(d, sizeof d, "%02x", b[i]);
    out += d;
  }
  return out;
}

}  // namespace

TEST_CASE("tiny: SipHash-2-4 gives the reference (and libsodium's) values", "[unit][tiny]") {
  // Key 00..0f, message 00..len-1; the values computed with libsodium's
  // crypto_shorthash_siphash24 (the first is the reference's vector 0).
  const std::pair<size_t, const char*> vectors[] = {
      {0, "310e0edd47db6f72"},  {1, "fd67dc93c539f874"},  {7, "37d1018bf50002ab"},
      {8, "6224939a79f5f593"},  {15, "e545be4961ca29a1"}, {16, "db9bc2577fcc2a3f"},
      {63, "724506eb4c328a95"},
  };
  uint8_t key[16], msg[64], out[8];
  for (int i = 0; i < 16; ++i) key[i] = static_cast<uint8_t>(i);
  for (int i = 0; i < 64; ++i) msg[i] = static_cast<uint8_t>(i);
  for (const auto& [len, expected] : vectors) {
    INFO("length " << len);
    tiny_siphash24(key, msg, len, out);
    CHECK(hexOf(out, 8) == expected);
  }
}

TEST_CASE(
    "tiny: secured frames: a bad MAC, an old counter, an unknown or unsecured sender are "
    "dropped and counted",
    "[unit][tiny]") {
  Bus bus;
  auto* plant = bus.add(3);
  auto* blind = bus.add(4);
  auto* stranger = bus.add(9);
  REQUIRE(tiny_secure(plant, kKeyA) == TINY_OK);
  REQUIRE(tiny_secure(blind, kKeyB) == TINY_OK);
  REQUIRE(tiny_secure(stranger, kKeyB) == TINY_OK);
  REQUIRE(tiny_trust(blind, 3, kKeyA, 0) == TINY_OK);
  REQUIRE(tiny_trust(plant, 4, kKeyB, 0) == TINY_OK);  // the blind's subscriptions
  Seen seen;
  const tiny_key tilt = tiny_key1(43);
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, &Seen::cb, &seen) >= 0);
  bus.run(100);
  REQUIRE(tiny_set(plant, &tilt, "0", 1) == TINY_OK);
  bus.run(100);
  REQUIRE(!seen.tuples.empty());
  const auto* got = tiny_get(blind, 3, &tilt);
  REQUIRE(got != nullptr);
  CHECK(dataOf(got) == "0");

  // Every frame on the air is secured: version 2, counter and MAC.
  for (const auto& f : bus.sent) {
    REQUIRE(f.size() >= TINY_FRAME_HEADER_SIZE + TINY_SECURED_OVERHEAD);
    CHECK(f[TINY_FOFF_VERSION] == TINY_SECURED_VERSION);
  }
  // The plant's last tuple frame, to tamper with and replay.
  Bytes last;
  for (const auto& f : bus.sent)
    if (f[0] == TINY_FRAME_TUPLE && (f[2] | f[3] << 8) == 3) last = f;
  REQUIRE(!last.empty());
  const auto s0 = *tiny_get_stats(blind);
  auto& inbox = bus.node(blind).inbox;
  Bytes bad = last;
  bad[TINY_FRAME_HEADER_SIZE + TINY_OFF_STORAGE + 2] ^= 0x01;  // the data
  inbox.push_back(bad);
  inbox.push_back(last);  // its counter was taken already
  Bytes open = last;      // the same frame, unsecured
  open.resize(open.size() - TINY_SECURED_OVERHEAD);
  open[TINY_FOFF_VERSION] = TINY_PROTOCOL_VERSION;
  inbox.push_back(open);
  bus.run(20);
  // A sender the blind holds no key of.
  REQUIRE(tiny_set(stranger, &tilt, "1", 1) == TINY_OK);    // nobody subscribes: no frame
  tiny_subscribe(stranger, 4, &tilt, 0, nullptr, nullptr);  // its SUBSCRIBE reaches the blind
  bus.run(50);
  const auto& s1 = *tiny_get_stats(blind);
  CHECK(s1.drop_bad_mac == s0.drop_bad_mac + 1);
  CHECK(s1.drop_replay == s0.drop_replay + 1);
  CHECK(s1.drop_unsecured == s0.drop_unsecured + 1);
  CHECK(s1.drop_unknown_sender > s0.drop_unknown_sender);
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "0");
  // The plant's later values still arrive.
  REQUIRE(tiny_set(plant, &tilt, "7", 1) == TINY_OK);
  bus.run(50);
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "7");
}

TEST_CASE("tiny: on a secured radio only the bridge writes, and a node speaks for its own tuples",
          "[unit][tiny]") {
  Bus bus;
  auto* lamp = bus.add(7);
  auto* plant = bus.add(3);
  auto* bridge = bus.add(0xFFFE);
  for (auto* k : {lamp, plant}) REQUIRE(tiny_secure(k, kKeyA) == TINY_OK);
  REQUIRE(tiny_secure(bridge, kKeyBridge) == TINY_OK);
  REQUIRE(tiny_trust(lamp, 3, kKeyA, 0) == TINY_OK);
  REQUIRE(tiny_trust(lamp, 0xFFFE, kKeyBridge, 1) == TINY_OK);
  const tiny_key level = tiny_key1(42);
  tiny_tuple request{};
  request.owner = 7;
  request.creator = 3;
  tiny_tuple_set_key_data(&request, &level, "100", 3);
  uint8_t buf[TINY_FRAME_MAX];
  // The plant asks the lamp to write: refused; the bridge asks: applied.
  size_t n = tiny_encode_write_frame(buf, 3, 1, &request);
  n = tiny_seal_frame(buf, n, kKeyA, 1000);
  bus.node(lamp).inbox.emplace_back(buf, buf + n);
  bus.run(20);
  CHECK(tiny_get(lamp, 7, &level) == nullptr);
  CHECK(tiny_get_stats(lamp)->writes_refused == 1);
  n = tiny_encode_write_frame(buf, 0xFFFE, 1, &request);
  n = tiny_seal_frame(buf, n, kKeyBridge, 1000);
  bus.node(lamp).inbox.emplace_back(buf, buf + n);
  bus.run(20);
  REQUIRE(tiny_get(lamp, 7, &level) != nullptr);
  CHECK(dataOf(tiny_get(lamp, 7, &level)) == "100");
  // The plant sends a tuple "of" node 5: forged.
  Seen seen;
  REQUIRE(tiny_subscribe(lamp, TINY_ANY_OWNER, &level, 0, &Seen::cb, &seen) >= 0);
  tiny_tuple forged{};
  forged.owner = 5;
  forged.creator = 5;
  forged.seqno = 1;
  tiny_tuple_set_key_data(&forged, &level, "9", 1);
  n = tiny_encode_tuple_frame(buf, 3, 7, 2, &forged);
  n = tiny_seal_frame(buf, n, kKeyA, 1001);
  bus.node(lamp).inbox.emplace_back(buf, buf + n);
  bus.run(20);
  CHECK(tiny_get(lamp, 5, &level) == nullptr);
  CHECK(tiny_get_stats(lamp)->drop_forged_owner == 1);
  // Secured tuples hold 58 bytes of key and data.
  const std::string fits(56, 'x'), over(57, 'x');
  CHECK(tiny_set(plant, &level, fits.data(), static_cast<uint8_t>(fits.size())) == TINY_OK);
  CHECK(tiny_set(plant, &level, over.data(), static_cast<uint8_t>(over.size())) == TINY_ERR_ARG);
}

TEST_CASE("tiny: the frame counter survives a restart, so nothing is taken for a replay",
          "[unit][tiny]") {
  Bus bus;
  auto* plant = bus.add(3);
  auto* blind = bus.add(4);
  REQUIRE(tiny_secure(plant, kKeyA) == TINY_OK);
  REQUIRE(tiny_secure(blind, kKeyB) == TINY_OK);
  REQUIRE(tiny_trust(blind, 3, kKeyA, 0) == TINY_OK);
  REQUIRE(tiny_trust(plant, 4, kKeyB, 0) == TINY_OK);
  const tiny_key tilt = tiny_key1(43);
  REQUIRE(tiny_subscribe(blind, 3, &tilt, 0, nullptr, nullptr) >= 0);
  bus.run(3000);  // beacons, subscriptions, answers: many frames
  const uint32_t used = plant->counter;
  CHECK(bus.node(plant).storedCounter >= used);  // stored ahead of use
  const int writes = bus.node(plant).counterWrites;
  CHECK(writes <= 2 + static_cast<int>(used / TINY_COUNTER_BLOCK));
  bus.restart(plant);
  REQUIRE(tiny_secure(plant, kKeyA) == TINY_OK);
  REQUIRE(tiny_trust(plant, 4, kKeyB, 0) == TINY_OK);
  CHECK(plant->counter >= used);
  REQUIRE(tiny_set(plant, &tilt, "5", 1) == TINY_OK);
  bus.run(200);
  CHECK(dataOf(tiny_get(blind, 3, &tilt)) == "5");
  CHECK(tiny_get_stats(blind)->drop_replay == 0);
}
