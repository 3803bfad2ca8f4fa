// RawPeer: a hand-driven TCP connection to a PEIS; see raw_peer.h.
#include "raw_peer.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cerrno>

namespace peis::test {

std::string frameOf(const wire::LinkMessage& message) {
  std::string out;
  wire::encode(message, out);
  return out;
}

std::string frameOf(const wire::RoutedMessage& message) { return wire::encodeFrame(message); }

std::string helloFrame(const std::string& ecology, PeisId id, std::uint16_t version) {
  wire::Hello h;
  h.version = version;
  h.ecology = ecology;
  h.id = id;
  h.incarnation = 1ull << 62;  // "started later" than any real PEIS here
  h.name = "raw";
  return frameOf(wire::LinkMessage{h});
}

RawPeer::RawPeer(std::uint16_t port, int receiveBuffer) {
  fd_ = socket(AF_INET, SOCK_STREAM, 0);
  REQUIRE(fd_ >= 0);
  if (receiveBuffer > 0) {
    setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receiveBuffer, sizeof receiveBuffer);
  }
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  REQUIRE(connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0);
  timeval timeout{10, 0};
  setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  // A writer that never reads must not block the test for ever either.
  setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
}

RawPeer::~RawPeer() {
  if (fd_ >= 0) close(fd_);
}

bool RawPeer::send(const std::string& bytes) {
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    const auto n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;  // the PEIS may already have hung up on us
    sent += static_cast<std::size_t>(n);
  }
  return true;
}

bool RawPeer::closedByPeer() {
  char buffer[4096];
  while (true) {
    const auto n = recv(fd_, buffer, sizeof buffer, 0);
    if (n == 0) return true;
    if (n < 0) return errno != EAGAIN && errno != EWOULDBLOCK;
  }
}

bool RawPeer::closedWithin(std::chrono::milliseconds timeout) {
  pollfd poll{fd_, POLLIN, 0};
  if (::poll(&poll, 1, static_cast<int>(timeout.count())) <= 0) return false;
  char buffer[4096];
  const auto n = recv(fd_, buffer, sizeof buffer, MSG_DONTWAIT);
  if (n > 0) in_.append(buffer, static_cast<std::size_t>(n));
  return n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK);
}

std::optional<std::string> RawPeer::readFrame(std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (true) {
    if (in_.size() >= 4) {
      const auto length = wire::frameLength(in_);
      if (in_.size() >= 4 + length) {
        auto frame = in_.substr(4, length);
        in_.erase(0, 4 + length);
        return frame;
      }
    }
    if (std::chrono::steady_clock::now() >= until) return std::nullopt;
    char buffer[65536];
    const auto n = recv(fd_, buffer, sizeof buffer, 0);
    if (n == 0) return std::nullopt;
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
      return std::nullopt;
    }
    in_.append(buffer, static_cast<std::size_t>(n));
  }
}

}  // namespace peis::test
