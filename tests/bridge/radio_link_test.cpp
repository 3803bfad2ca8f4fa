// Unit tests of the tinybridge's radio links (bridge/src/radio_link.h): the
// link spec, and the serial link over a UNIX socket.
#include "radio_link.h"

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "peis/error.h"
#include "support/error_matchers.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"
#include "tiny_serial.h"

using Catch::Matchers::Contains;
using peis::Error;
using peis::ErrorCode;
using peis::bridge::Frame;
using peis::bridge::openRadioLink;
using peis::test::HasCode;
using peis::test::TempDir;

namespace {

// A listening UNIX stream socket: the other end of a serial link (an
// emulated MCU's UART).
struct Listener {
  int fd = -1;
  explicit Listener(const std::string& path) {
    fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    REQUIRE(fd >= 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    REQUIRE(path.size() < sizeof addr.sun_path);
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
    REQUIRE(::listen(fd, 4) == 0);
  }
  ~Listener() { ::close(fd); }
  Listener(const Listener&) = delete;
  Listener& operator=(const Listener&) = delete;
  // The next connection, or -1 after 2 s.
  int accept() const {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 2000) != 1) return -1;
    return ::accept4(fd, nullptr, nullptr, SOCK_CLOEXEC);
  }
};

// Reads from `fd` until one whole serial frame decodes (2 s at most).
std::optional<Frame> readSerialFrame(int fd) {
  tiny_serial_rx rx;
  tiny_serial_rx_init(&rx);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) != 1) continue;
    std::uint8_t byte = 0;
    if (::read(fd, &byte, 1) != 1) return std::nullopt;
    if (const auto len = tiny_serial_rx_byte(&rx, byte); len > 0)
      return Frame(rx.buf, rx.buf + len);
  }
  return std::nullopt;
}

// The frames `link` receives within 2 s, once there is at least one.
std::vector<Frame> receiveSome(peis::bridge::RadioLink& link) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{link.fd(), POLLIN, 0};
    if (link.fd() >= 0) ::poll(&p, 1, 100);
    auto frames = link.receive();
    if (!frames.empty()) return frames;
  }
  return {};
}

}  // namespace

TEST_CASE("openRadioLink refuses a bad spec with InvalidArgument naming it",
          "[unit][bridge][link]") {
  for (const std::string spec :
       {"", "bogus", "medium:", "medium:0", "medium:70000", "medium:47000:1", "medium:47000:65",
        "medium:47000:", "medium:x", "medium:65530:64", "unix:", "/dev/ttyS0:12345",
        "/dev/ttyS0:", "/dev/ttyS0:fast", "tcp:localhost:1", "dev/ttyS0"}) {
    INFO("spec '" << spec << "'");
    try {
      openRadioLink(spec);
      FAIL_CHECK("no exception");
    } catch (const Error& e) {
      CHECK(e.code() == ErrorCode::InvalidArgument);
      CHECK_THAT(e.what(), Contains("radio link '" + spec + "'"));
    }
  }
}

TEST_CASE("openRadioLink says what is wrong with a spec", "[unit][bridge][link]") {
  CHECK_THROWS_WITH(openRadioLink("bogus"), Contains("unknown kind of link"));
  CHECK_THROWS_WITH(openRadioLink("medium:0"), Contains("base port"));
  CHECK_THROWS_WITH(openRadioLink("medium:47000:1"), Contains("slot count"));
  CHECK_THROWS_WITH(openRadioLink("medium:65530:64"), Contains("passes 65535"));
  CHECK_THROWS_WITH(openRadioLink("unix:"), Contains("no socket path"));
  CHECK_THROWS_WITH(openRadioLink("/dev/ttyS0:12345"), Contains("baud"));
  REQUIRE_THROWS_MATCHES(openRadioLink("bogus"), Error, HasCode(ErrorCode::InvalidArgument));
}

TEST_CASE("a serial link to a missing socket opens and counts failed sends",
          "[unit][bridge][link]") {
  auto link = openRadioLink("unix:/nonexistent/sock");
  REQUIRE(link);
  CHECK(link->fd() == -1);
  CHECK_THAT(link->describe(), Contains("/nonexistent/sock"));
  CHECK_FALSE(link->send(Frame{1, 2, 3}));
  CHECK(link->stats().sendErrors == 1);
  CHECK(link->stats().framesOut == 0);
  CHECK(link->receive().empty());
  // service() retries the connection, soon, and still fails.
  const int wait = link->service();
  CHECK(wait > 0);
  CHECK(wait <= 1000);
  CHECK(link->fd() == -1);
  CHECK(link->stats().reconnects == 0);
  CHECK_FALSE(link->send(Frame{4}));
  CHECK(link->stats().sendErrors == 2);
}

TEST_CASE("a serial link over a UNIX socket carries framed frames both ways",
          "[unit][bridge][link]") {
  TempDir dir;
  const auto path = (dir.path / "uart").string();
  Listener listener(path);
  auto link = openRadioLink("unix:" + path);
  const int peer = listener.accept();
  REQUIRE(peer >= 0);
  CHECK(link->fd() >= 0);

  SECTION("a frame out is framed on the wire") {
    const Frame frame{0x01, 0x02, 0x7E, 0xFF};
    REQUIRE(link->send(frame));
    CHECK(link->stats().framesOut == 1);
    CHECK(readSerialFrame(peer) == frame);
  }
  SECTION("a frame too long for the radio is not sent") {
    CHECK_FALSE(link->send(Frame(101, 0x55)));
    CHECK_FALSE(link->send(Frame{}));
    CHECK(link->stats().sendErrors == 2);
    CHECK(link->fd() >= 0);  // still connected
  }
  SECTION("frames in are decoded, noise is counted") {
    std::uint8_t wire[2 * TINY_SERIAL_MAX + 4];
    const std::uint8_t a[] = {9, 8, 7};
    const std::uint8_t b[] = {42};
    std::size_t n = 0;
    wire[n++] = 0x00;  // noise before the first start byte
    n += tiny_serial_encode(wire + n, a, sizeof a);
    n += tiny_serial_encode(wire + n, b, sizeof b);
    wire[n - 1] ^= 0x01;  // b's checksum is wrong
    n += tiny_serial_encode(wire + n, b, sizeof b);
    REQUIRE(::write(peer, wire, n) == static_cast<ssize_t>(n));
    std::vector<Frame> frames;
    for (int turn = 0; turn < 20 && frames.size() < 2; ++turn) {
      for (auto& frame : receiveSome(*link)) frames.push_back(std::move(frame));
    }
    CHECK(frames == std::vector<Frame>{{9, 8, 7}, {42}});
    CHECK(link->stats().framesIn == 2);
    CHECK(link->stats().badSerialBytes >= 1);
  }
  SECTION("a closed connection is re-opened by service()") {
    ::close(peer);
    REQUIRE(peis::test::waitFor(
        [&] {
          link->receive();
          return link->fd() == -1;
        },
        std::chrono::seconds(2)));
    CHECK_FALSE(link->send(Frame{1}));
    link->service();
    CHECK(link->fd() >= 0);
    CHECK(link->stats().reconnects == 1);
    const int again = listener.accept();
    REQUIRE(again >= 0);
    REQUIRE(link->send(Frame{5, 6}));
    CHECK(readSerialFrame(again) == Frame{5, 6});
    ::close(again);
    return;
  }
  ::close(peer);
}

TEST_CASE("a serial link on a tty device (a pty here) carries framed frames both ways",
          "[unit][bridge][link]") {
  int master = -1, slave = -1;
  char name[128] = {};
  REQUIRE(::openpty(&master, &slave, name, nullptr, nullptr) == 0);
  ::close(slave);  // the link opens the device by its name
  auto link = openRadioLink(std::string(name) + ":115200");
  REQUIRE(link->fd() >= 0);
  CHECK_THAT(link->describe(), Contains(name));

  const Frame out{0x04, 0x01, 0x07, 0x00};
  REQUIRE(link->send(out));
  CHECK(readSerialFrame(master) == out);

  std::uint8_t wire[TINY_SERIAL_MAX];
  const std::uint8_t in[] = {0x01, 0x7E, 0x03};
  const auto n = tiny_serial_encode(wire, in, sizeof in);
  REQUIRE(::write(master, wire, n) == static_cast<ssize_t>(n));
  CHECK(receiveSome(*link) == std::vector<Frame>{{0x01, 0x7E, 0x03}});
  ::close(master);
}
