// Test helper: a client of peis-view's HTTP and WebSocket protocol, as a
// browser would be one (Boost.Beast, kept out of this header). Every wait
// has a deadline.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace peis::test {

struct HttpResult {
  int status = 0;
  std::string contentType;
  std::string body;
};

// GET `target` from 127.0.0.1:`port` with the Host header `host` and
// `headers` besides.
HttpResult httpGet(std::uint16_t port, const std::string& target,
                   const std::string& host = "127.0.0.1",
                   const std::vector<std::pair<std::string, std::string>>& headers = {});

class ViewSocket {
 public:
  // Opens ws://127.0.0.1:port/ws, sending `origin` as Origin when not
  // empty; `receiveBuffer` > 0 shrinks the socket's receive buffer (a slow
  // page). Throws std::runtime_error with the reason when refused.
  explicit ViewSocket(std::uint16_t port, const std::string& origin = "", int receiveBuffer = 0);
  ~ViewSocket();
  ViewSocket(const ViewSocket&) = delete;
  ViewSocket& operator=(const ViewSocket&) = delete;

  void send(const std::string& text);
  void sendBinary(const std::string& bytes);
  // The next message within `timeout`; nothing at the deadline or when the
  // connection ended (then closed() is true).
  std::optional<std::string> next(std::chrono::milliseconds timeout);
  bool closed() const;
  // The close frame's code (0 when none came) and reason.
  int closeCode() const;
  std::string closeReason() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::test
