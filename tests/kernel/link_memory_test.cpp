// Memory after a burst: an idle Link goes back to small buffers after a
// burst of big reads and writes, and QuietTrim hands freed memory back
// once changes stop (docs/architecture.md, "Memory after a join").
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <catch2/catch.hpp>
#include <chrono>
#include <functional>
#include <string>

#include "net/counters.h"
#include "net/link.h"
#include "quiet_trim.h"
#include "support/run_io_until.h"

using namespace std::chrono_literals;
namespace asio = boost::asio;
using asio::ip::tcp;

namespace {

struct CountingHandler : peis::net::LinkHandler {
  int frames = 0;
  std::size_t bytes = 0;
  void onFrame(peis::net::Link&, std::string_view frame) override {
    ++frames;
    bytes += frame.size();
  }
  bool onOversize(peis::net::Link&, std::string_view) override { return false; }
  char* placeFrame(peis::net::Link&, std::string_view, std::size_t, std::size_t&) override {
    return nullptr;  // every frame read whole
  }
  char* reservePlace(peis::net::Link&, std::size_t) override { return nullptr; }
  bool placeReserved(peis::net::Link&, std::string_view, std::size_t) override { return false; }
  void onPlacedFrame(peis::net::Link&) override {}
  void onReadDone(peis::net::Link&) override {}
  void onWritten(peis::net::Link&) override {}
  void onClosed(peis::net::Link&, const std::string&) override {}
};

// One frame: a 4-byte big-endian length, then `body`.
std::string frame(const std::string& body) {
  std::string out(4, '\0');
  const auto n = static_cast<std::uint32_t>(body.size());
  for (int i = 0; i < 4; ++i) out[i] = static_cast<char>(n >> (24 - 8 * i));
  return out + body;
}

using peis::test::runIoUntil;

}  // namespace

TEST_CASE("an idle link lets go of the big buffers of a burst", "[unit][link]") {
  asio::io_context io;
  tcp::acceptor acceptor(io, tcp::endpoint(asio::ip::address_v4::loopback(), 0));
  tcp::socket peer(io);
  peer.connect(acceptor.local_endpoint());
  tcp::socket ours = acceptor.accept();
  CountingHandler handler;
  peis::net::Counters counters;
  auto link =
      std::make_shared<peis::net::Link>(handler, counters, 1 << 20, std::move(ours), false, -1);
  link->start(peis::wire::Hello{});
  link->establish();  // past the handshake: frames up to the link's limit

  // A burst: 2 MiB of 20 KiB frames fills the reads (the buffer grows), and
  // a big frame is queued to be written (the write chunk grows).
  std::string burst;
  for (int i = 0; i < 100; ++i) burst += frame(std::string(20 * 1024, 'x'));
  asio::write(peer, asio::buffer(burst));
  link->sendFrame(frame(std::string(100 * 1024, 'y')));
  REQUIRE(runIoUntil(io, [&] { return handler.frames == 100; }));
  const auto afterBurst = link->bufferBytes();
  CHECK(afterBurst > 32 * 1024);

  // Small frames one at a time (pings): the buffers shrink back.
  for (int i = 0; i < 20 && link->bufferBytes() > 8 * 1024; ++i) {
    asio::write(peer, asio::buffer(frame("ping")));
    link->sendFrame(frame("pong"));
    const int want = 101 + i;
    REQUIRE(runIoUntil(io, [&] { return handler.frames == want; }));
  }
  CHECK(link->bufferBytes() <= 8 * 1024);
  link->close("test over");
}

TEST_CASE("QuietTrim trims once, after the changes stop", "[unit][link]") {
  asio::io_context io;
  peis::QuietTrim trim(
      io, [] { return std::uint64_t{0}; }, 20ms);
  trim.noteChange();
  trim.noteChange();  // within the quiet period: still one trim
  REQUIRE(runIoUntil(io, [&] { return trim.trims() == 1; }));
  io.restart();
  io.run_for(100ms);  // nothing changed: no further trim
  CHECK(trim.trims() == 1);
  trim.noteChange();
  REQUIRE(runIoUntil(io, [&] { return trim.trims() == 2; }));
  trim.stop();
}

TEST_CASE("QuietTrim waits while data moves", "[unit][link]") {
  asio::io_context io;
  std::uint64_t frames = 0;
  int checks = 0;
  // Every look at the count sees a stream: 5,000 more frames.
  peis::QuietTrim trim(
      io,
      [&] {
        ++checks;
        return frames += 5000;
      },
      10ms);
  trim.noteChange();
  REQUIRE(runIoUntil(io, [&] { return checks >= 6; }));  // several quiet periods went by
  CHECK(trim.trims() == 0);
  trim.stop();
}
