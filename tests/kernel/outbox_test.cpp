// Unit tests of the outbox alone (outbox.h): per-destination queues, what a
// congested destination's queue does (waits, coalesces, is cut off) while
// every other destination is served, and per-destination order.
#include "outbox.h"

#include <catch2/catch.hpp>
#include <memory>
#include <string>
#include <vector>

using peis::Outbox;
using peis::PeisId;
using peis::Tuple;
using peis::TuplePtr;
namespace wire = peis::wire;

namespace {

constexpr PeisId kSelf = 1;

TuplePtr tuple(const std::string& key, std::string data, std::uint64_t seqno) {
  auto t = std::make_shared<Tuple>();
  t->owner = kSelf;
  t->creator = kSelf;
  t->key = key;
  t->data = std::move(data);
  t->seqno = seqno;
  return t;
}

// The data of every update to `destination` in `taken`, in order (frames
// decoded), and "<message>" for anything else.
std::vector<std::string> sentTo(PeisId destination, const std::vector<Outbox::Outgoing>& taken) {
  std::vector<std::string> values;
  for (const auto& out : taken) {
    if (out.destination != destination) continue;
    if (out.update) values.push_back(out.update->data);
    if (out.body) values.push_back("<message>");
    std::string_view frames = out.frames;
    while (!frames.empty()) {
      const auto length = wire::frameLength(frames);
      auto decoded = wire::decode(frames.substr(wire::kFrameHeaderBytes, length), 64 << 20);
      REQUIRE(decoded.message);
      const auto& routed = std::get<wire::RoutedMessage>(*decoded.message);
      values.push_back(std::get<wire::TupleUpdate>(routed.body).tuple.data);
      frames.remove_prefix(wire::kFrameHeaderBytes + length);
    }
  }
  return values;
}

}  // namespace

TEST_CASE("outbox: a blocked destination waits, the others are served", "[unit][outbox]") {
  Outbox outbox(kSelf, 7);
  outbox.pushUpdate(9, tuple("a", "9-1", 1));
  outbox.pushUpdate(4, tuple("a", "4-1", 1));
  outbox.push(Outbox::Outgoing{9, nullptr, wire::Unsubscribe{3}});
  outbox.pushUpdate(4, tuple("a", "4-2", 2));
  auto slow = [](PeisId destination) { return destination == 9; };

  std::vector<Outbox::Outgoing> taken;
  CHECK_FALSE(outbox.take(taken, SIZE_MAX, SIZE_MAX, slow));
  CHECK(sentTo(4, taken) == std::vector<std::string>{"4-1", "4-2"});
  CHECK(sentTo(9, taken).empty());
  CHECK(outbox.blocked() == std::vector<PeisId>{9});
  CHECK_FALSE(outbox.hasReady());  // nothing to flush until 9's link drains
  CHECK_FALSE(outbox.empty());
  CHECK(outbox.waitingFor(9) > outbox.bytesFor(9));  // the Unsubscribe counts too

  outbox.pushUpdate(4, tuple("a", "4-3", 3));  // another destination: ready at once
  CHECK(outbox.hasReady());
  outbox.unblockAll();
  taken.clear();
  CHECK_FALSE(outbox.take(taken));
  CHECK(sentTo(9, taken) == std::vector<std::string>{"9-1", "<message>"});
  CHECK(sentTo(4, taken) == std::vector<std::string>{"4-3"});
  CHECK(outbox.empty());
  CHECK(outbox.bytes() == 0);
}

TEST_CASE("outbox: only a backed-up destination coalesces, never across a message",
          "[unit][outbox]") {
  Outbox outbox(kSelf, 7);
  auto slow = [](PeisId destination) { return destination == 9; };
  const std::string big(64 * 1024, 'x');
  std::vector<Outbox::Outgoing> taken;
  // 9 does not read: its updates pile up; 4 keeps up (taken every round).
  std::uint64_t seqno = 0;
  for (int i = 0; outbox.bytesFor(9) < Outbox::kCoalesceAbove; ++i) {
    ++seqno;
    outbox.pushUpdate(9, tuple("fill." + std::to_string(i), big, seqno));
    outbox.pushUpdate(4, tuple("fill." + std::to_string(i), big, seqno));
    outbox.take(taken, SIZE_MAX, SIZE_MAX, slow);
  }
  CHECK(outbox.coalesced() == 0);
  for (const auto* value : {"v1", "v2", "v3"}) {
    ++seqno;
    outbox.pushUpdate(9, tuple("x", value, seqno));
    outbox.pushUpdate(4, tuple("x", value, seqno));
    outbox.take(taken, SIZE_MAX, SIZE_MAX, slow);
  }
  CHECK(outbox.coalesced() == 2);  // v1 and v2 waited for 9 and were replaced
  CHECK(outbox.bytesFor(4) == 0);
  outbox.push(Outbox::Outgoing{9, nullptr, wire::Unsubscribe{1}});
  outbox.pushUpdate(9, tuple("x", "v4", ++seqno));  // behind the message: no replacing
  CHECK(outbox.coalesced() == 2);

  outbox.unblockAll();
  outbox.take(taken);
  std::vector<std::string> toFourX, toNineX;
  for (const auto& v : sentTo(4, taken)) {
    if (v.size() < 10) toFourX.push_back(v);
  }
  for (const auto& v : sentTo(9, taken)) {
    if (v.size() < 10) toNineX.push_back(v);
  }
  CHECK(toFourX == std::vector<std::string>{"v1", "v2", "v3"});  // every value
  CHECK(toNineX == std::vector<std::string>{"v3", "<message>", "v4"});
}

TEST_CASE("outbox: limits per turn, drop and a new id", "[unit][outbox]") {
  Outbox outbox(kSelf, 7);
  for (PeisId destination : {5, 6, 7}) {
    outbox.push(Outbox::Outgoing{destination, nullptr, wire::Unsubscribe{1}});
    outbox.push(Outbox::Outgoing{destination, nullptr, wire::Unsubscribe{2}});
  }
  std::vector<Outbox::Outgoing> taken;
  CHECK(outbox.take(taken, 3));  // more is left
  REQUIRE(taken.size() == 3);
  CHECK(taken[0].destination == 5);
  CHECK(taken[1].destination == 5);
  CHECK(taken[2].destination == 6);
  outbox.drop(6);
  outbox.drop(7);
  outbox.pushUpdate(8, tuple("k", "encoded with the old id", 1));
  outbox.changeSelf(2);  // frames say source 1: dropped
  CHECK(outbox.bytesFor(8) == 0);
  taken.clear();
  CHECK_FALSE(outbox.take(taken));
  CHECK(taken.empty());
  CHECK(outbox.empty());
}

TEST_CASE("outbox: frames written into a recycled buffer that must grow decode whole",
          "[unit][outbox]") {
  // A stream's frames are written into an entry's buffer sized without
  // zero-filling; a buffer handed back small (a direct send's) grows under
  // them. Keys, sizes and the repeated fields change from frame to frame.
  Outbox outbox(kSelf, 7);
  std::string small;
  small.reserve(100);
  outbox.recycleFrames(std::move(small));
  std::vector<std::string> expected;
  for (int i = 0; i < 600; ++i) {
    std::string data(i % 7 == 0 ? 2048 : 16, static_cast<char>('a' + i % 3));
    data += std::to_string(i);
    expected.push_back(data);
    outbox.pushUpdate(9, tuple("stress." + std::to_string(i % 3), data, i + 1));
  }
  std::vector<Outbox::Outgoing> taken;
  outbox.take(taken);
  CHECK(sentTo(9, taken) == expected);
}
