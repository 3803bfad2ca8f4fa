// Test helper: a TCP connection to a PEIS that the test drives by hand,
// frame by frame, as a PEIS that misbehaves would (garbage, spoofing, a
// reader that stops reading, a writer that never reads). Blocking sockets
// with a receive timeout; the connection is closed by the destructor.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "net/wire.h"

namespace peis::test {

// One whole frame (length prefix included).
std::string frameOf(const wire::LinkMessage& message);
std::string frameOf(const wire::RoutedMessage& message);
// A Hello of `ecology` from `id`, "started later" than any real PEIS here.
std::string helloFrame(const std::string& ecology, PeisId id,
                       std::uint16_t version = wire::kVersion);

class RawPeer {
 public:
  // Connects to 127.0.0.1:port (the test fails if it cannot). A positive
  // `receiveBuffer` shrinks the socket's receive buffer first (a slow reader
  // then backs up its sender sooner).
  explicit RawPeer(std::uint16_t port, int receiveBuffer = 0);
  RawPeer(const RawPeer&) = delete;
  RawPeer& operator=(const RawPeer&) = delete;
  ~RawPeer();

  int fd() const { return fd_; }
  // Sends every byte; false if the PEIS hung up first.
  bool send(const std::string& bytes);
  // True once the PEIS closed the connection (read returns 0 or an error
  // other than a timeout), draining whatever it sent before.
  bool closedByPeer();
  // The same, waiting at most `timeout` (false while it is still open).
  bool closedWithin(std::chrono::milliseconds timeout);
  // The next whole frame's type and body (nullopt on a timeout or close).
  std::optional<std::string> readFrame(std::chrono::milliseconds timeout);

 private:
  int fd_ = -1;
  std::string in_;
};

}  // namespace peis::test
