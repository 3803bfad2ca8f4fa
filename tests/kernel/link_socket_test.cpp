// LinkSocket's read (net/link_socket.h): after a read that found the socket
// drained, the next read waits for epoll without trying the socket first;
// bytes that arrive at any moment (before that read is asked for, while it
// waits, or together with the end of the stream) are still read, in order.
#include "net/link_socket.h"

#include <array>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>
#include <catch2/catch.hpp>
#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "support/run_io_until.h"

using namespace std::chrono_literals;
namespace asio = boost::asio;
using asio::ip::tcp;
using peis::net::LinkSocket;

namespace {

struct Reader {
  asio::io_context io;
  tcp::acceptor acceptor{io, tcp::endpoint(asio::ip::address_v4::loopback(), 0)};
  tcp::socket peer{io};
  std::unique_ptr<LinkSocket> socket;
  std::string received;
  boost::system::error_code error;
  int reads = 0;
  char buffer[64];

  Reader() {
    peer.connect(acceptor.local_endpoint());
    socket = std::make_unique<LinkSocket>(acceptor.accept());
  }
  // One read of at most sizeof buffer bytes, reporting a drained socket
  // when it takes fewer.
  void read() {
    socket->receiveDrained(std::array<asio::mutable_buffer, 1>{asio::buffer(buffer)}, true,
                           [this](const boost::system::error_code& ec, std::size_t n) {
                             ++reads;
                             error = ec;
                             received.append(buffer, n);
                           });
  }
  bool runUntil(const std::function<bool()>& done) { return peis::test::runIoUntil(io, done); }
};

}  // namespace

TEST_CASE("a read after a drained one gets the bytes however their arrival falls", "[unit][link]") {
  Reader reader;
  std::string sent;
  for (int i = 0; i < 40; ++i) {
    const std::string piece = "piece " + std::to_string(i) + ";";
    const int before = reader.reads;
    switch (i % 3) {
      case 0:  // sent while no read is asked for
        asio::write(reader.peer, asio::buffer(piece));
        reader.read();
        break;
      case 1:  // sent while the read waits
        reader.read();
        reader.io.restart();
        reader.io.run_for(1ms);
        asio::write(reader.peer, asio::buffer(piece));
        break;
      default: {  // sent, and its epoll event taken, before the read is asked for
        asio::write(reader.peer, asio::buffer(piece));
        asio::steady_timer wait(reader.io, 2ms);  // work: epoll runs
        wait.async_wait([](const boost::system::error_code&) {});
        reader.io.restart();
        reader.io.run();
        reader.read();
        break;
      }
    }
    sent += piece;
    REQUIRE(reader.runUntil([&] { return reader.reads > before; }));
    REQUIRE_FALSE(reader.error);
    // A read takes what has arrived; the rest comes with the next reads.
    while (reader.received.size() < sent.size()) {
      const int now = reader.reads;
      reader.read();
      REQUIRE(reader.runUntil([&] { return reader.reads > now; }));
      REQUIRE_FALSE(reader.error);
    }
  }
  CHECK(reader.received == sent);

  SECTION("a full read leaves the next one to try first, and the end of the stream is read") {
    const std::string many(3 * sizeof reader.buffer, 'm');
    asio::write(reader.peer, asio::buffer(many));
    reader.peer.shutdown(tcp::socket::shutdown_send);
    while (!reader.error) {
      const int now = reader.reads;
      reader.read();
      REQUIRE(reader.runUntil([&] { return reader.reads > now; }));
    }
    CHECK(reader.error == asio::error::eof);
    CHECK(reader.received == sent + many);
  }
  SECTION("a read waiting when the socket closes ends with an error") {
    reader.read();
    const int now = reader.reads;
    reader.socket->close();
    REQUIRE(reader.runUntil([&] { return reader.reads > now; }));
    CHECK(reader.error == asio::error::operation_aborted);
  }
}
