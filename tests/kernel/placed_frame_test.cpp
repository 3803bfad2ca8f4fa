// Placed frames (net/link.h): a big frame's bytes after its head are read
// straight into the place its handler names, or into a place reserved in
// advance for a frame like the last; frames stay whole and in order
// whatever the reads cut, and a frame unlike the expected one is put back
// together.
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <catch2/catch.hpp>
#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "net/counters.h"
#include "net/link.h"
#include "support/run_io_until.h"

using namespace std::chrono_literals;
namespace asio = boost::asio;
using asio::ip::tcp;
using peis::net::Link;

namespace {

// Places frames that begin with 'P': their first kHead bytes are the head,
// the rest goes to `place`. Every frame, placed or not, ends up in
// `frames`, in the order the link handed them over.
struct PlacingHandler : peis::net::LinkHandler {
  static constexpr std::size_t kHead = 8;
  std::vector<std::string> frames;
  std::string head, place, reserved;
  int placed = 0, reservedTaken = 0, reservedRefused = 0;

  void onFrame(Link&, std::string_view frame) override { frames.emplace_back(frame); }
  // An oversized frame is answered from its head and the rest skipped.
  bool onOversize(Link&, std::string_view head) override {
    frames.push_back("oversize " + std::string(head.substr(0, 1)));
    return true;
  }
  char* placeFrame(Link&, std::string_view h, std::size_t length, std::size_t& from) override {
    if (h[0] != 'P') return nullptr;
    head = h.substr(0, kHead);
    from = kHead;
    place.assign(length - kHead, '\0');
    return place.data();
  }
  char* reservePlace(Link&, std::size_t bytes) override {
    reserved.assign(bytes, '\0');
    return reserved.data();
  }
  bool placeReserved(Link&, std::string_view h, std::size_t) override {
    if (h.size() != kHead || h[0] != 'P') {
      ++reservedRefused;
      return false;
    }
    head = h;
    place = std::move(reserved);  // the bytes the link read (and reads) there
    ++reservedTaken;
    return true;
  }
  void onPlacedFrame(Link&) override {
    ++placed;
    frames.push_back(head + place);
  }
  void onReadDone(Link&) override {}
  void onWritten(Link&) override {}
  void onClosed(Link&, const std::string&) override {}
};

std::string frame(const std::string& body) {
  std::string out(4, '\0');
  const auto n = static_cast<std::uint32_t>(body.size());
  for (int i = 0; i < 4; ++i) out[i] = static_cast<char>(n >> (24 - 8 * i));
  return out + body;
}

// A big body: `type`, then bytes that differ from position to position.
std::string big(char type, std::size_t bytes, int seed) {
  std::string body(bytes, '\0');
  body[0] = type;
  for (std::size_t i = 1; i < bytes; ++i) body[i] = static_cast<char>('a' + (i * 7 + seed) % 26);
  return body;
}

using peis::test::runIoUntil;

struct Pair {
  asio::io_context io;
  tcp::acceptor acceptor{io, tcp::endpoint(asio::ip::address_v4::loopback(), 0)};
  tcp::socket peer{io};
  PlacingHandler handler;
  peis::net::Counters counters;
  std::shared_ptr<Link> link;
  explicit Pair(std::size_t maxFrameBytes = 1 << 20) {
    peer.connect(acceptor.local_endpoint());
    link = std::make_shared<Link>(handler, counters, maxFrameBytes, acceptor.accept(), false, -1);
    link->start(peis::wire::Hello{});
    link->establish();
  }
  ~Pair() { link->close("test over"); }
  // Sends `bodies` as frames, `piece` bytes per write (0: all at once), and
  // waits until the link has handed over `bodies.size()` more frames.
  void send(const std::vector<std::string>& bodies, std::size_t piece = 0) {
    std::string bytes;
    for (const auto& body : bodies) bytes += frame(body);
    const auto want = handler.frames.size() + bodies.size();
    for (std::size_t at = 0; at < bytes.size();) {
      const auto n = piece == 0 ? bytes.size() : std::min(piece, bytes.size() - at);
      asio::write(peer, asio::buffer(bytes.data() + at, n));
      at += n;
      if (piece != 0) {
        io.restart();
        io.run_for(1ms);
      }
    }
    REQUIRE(runIoUntil(io, [&] { return handler.frames.size() >= want; }));
  }
};

}  // namespace

TEST_CASE("a big frame is read into its place and in order with the frames around it",
          "[unit][link]") {
  Pair pair;
  const std::vector<std::string> bodies{
      "s1", big('P', 40000, 1), "s2", big('P', 70000, 2), big('Q', 50000, 3),
      "s3", big('P', 40000, 4)};
  SECTION("all in one write") { pair.send(bodies); }
  SECTION("in pieces that cut heads and data anywhere") { pair.send(bodies, 997); }
  CHECK(pair.handler.frames == bodies);
  CHECK(pair.handler.placed >= 1);
  CHECK(pair.counters.malformedFrames == 0);
}

TEST_CASE("the frame after a placed one is read into a place reserved for one like it",
          "[unit][link]") {
  Pair pair;
  std::vector<std::string> sent;
  for (int i = 0; i < 4; ++i) {  // one at a time: each read begins a frame
    sent.push_back(big('P', 40000, i));
    pair.send({sent.back()});
  }
  CHECK(pair.handler.frames == sent);
  CHECK(pair.handler.placed == 4);
  CHECK(pair.handler.reservedTaken >= 1);

  SECTION("a frame unlike it is put back together, and so are small ones") {
    const std::vector<std::string> unlike{big('Q', 40000, 9)};  // its length, not its kind
    pair.send(unlike);
    sent.insert(sent.end(), unlike.begin(), unlike.end());
    pair.send({big('P', 40000, 10)});  // placed again: one like it is expected again
    sent.push_back(big('P', 40000, 10));
    const std::vector<std::string> smalls{"a small frame", std::string(300, 's'), "x"};
    pair.send(smalls);
    sent.insert(sent.end(), smalls.begin(), smalls.end());
    pair.send({big('P', 45000, 11)});  // longer than expected
    sent.push_back(big('P', 45000, 11));
    CHECK(pair.handler.frames == sent);
    CHECK(pair.handler.reservedRefused >= 1);
  }
}

TEST_CASE("the rest of an oversized frame after a placed one is skipped and not placed",
          "[unit][link]") {
  Pair pair(100 * 1024);  // frames over 100 KiB are oversized here
  const auto first = big('P', 40000, 1);
  pair.send({first});
  // Skipped bytes that look like a frame like the last placed one.
  std::string oversized = big('O', 300 * 1024, 2);
  const auto lookalike = frame(big('P', 40000, 3));
  oversized.replace(200 * 1024, lookalike.size(), lookalike);
  const auto after = big('P', 40000, 4);
  pair.send({oversized, after, "s"});
  CHECK(pair.handler.frames == std::vector<std::string>{first, "oversize O", after, "s"});
  CHECK(pair.counters.malformedFrames == 0);
}
