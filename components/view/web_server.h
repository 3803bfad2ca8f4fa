// The view's HTTP and WebSocket server (Boost.Beast, kept out of this
// header): one thread of its own, apart from the kernel's, serving GET
// requests through a handler and WebSocket connections on /ws. Only for
// this machine: it answers requests whose Host is localhost, 127.0.0.1 or
// [::1] and WebSocket upgrades whose Origin (when a browser sends one) is
// such a page, so a web site in the same browser cannot reach the ecology
// (DNS rebinding, cross-site WebSocket).
//
// Each WebSocket client has a send queue of its own, bounded in bytes; a
// client whose queue would pass the bound, or whose current message has
// not been taken for the stall timeout, is dropped (its connection closed)
// and counted. Nothing here blocks: a slow client only ever costs its own
// queue.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace peis::view {

struct HttpReply {
  int status = 200;
  std::string contentType = "text/plain; charset=utf-8";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
};

// One WebSocket connection. Used on the server thread only.
class WebClient {
 public:
  virtual ~WebClient() = default;
  virtual std::uint64_t id() const = 0;
  // Queues a text message; drops the client when its queue would pass the
  // bound. Does nothing once the client is closed.
  virtual void send(std::string text) = 0;
  // Nothing queued and nothing being written.
  virtual bool idle() const = 0;
  virtual bool closed() const = 0;
};

struct WebLimits {
  std::size_t maxMessageBytes = 2 << 20;  // a page's message; larger: closed with 1009
  std::size_t maxQueueBytes = 8 << 20;    // per client
  std::chrono::milliseconds stallTimeout{10000};
  std::chrono::milliseconds requestTimeout{30000};  // reading one HTTP request
};

struct WebHandlers {
  // GET of any target but /ws: path and raw query (after '?').
  std::function<HttpReply(const std::string& path, const std::string& query)> get;
  std::function<void(const std::shared_ptr<WebClient>&)> opened;
  std::function<void(const std::shared_ptr<WebClient>&, std::string message, bool binary)> message;
  std::function<void(const std::shared_ptr<WebClient>&, const std::string& why)> closed;
};

struct WebStats {
  std::atomic<std::uint64_t> clientsOpen{0};
  std::atomic<std::uint64_t> clientsAccepted{0};
  std::atomic<std::uint64_t> clientsDropped{0};         // both of:
  std::atomic<std::uint64_t> clientsDroppedQueue{0};    // its queue would pass the bound
  std::atomic<std::uint64_t> clientsDroppedStalled{0};  // took nothing for the stall timeout
  std::atomic<std::uint64_t> messagesSent{0};
  std::atomic<std::uint64_t> bytesSent{0};
  std::atomic<std::uint64_t> httpRequests{0};
  std::atomic<std::uint64_t> refusedRequests{0};  // bad request, wrong host or origin
};

class WebServer {
 public:
  // Listens on `address`:`port` (0: a free port). Throws std::runtime_error
  // saying why when it cannot (the port is taken, ...).
  WebServer(const std::string& address, std::uint16_t port, WebLimits limits, WebHandlers handlers);
  ~WebServer();  // stops the thread; open connections are closed
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  std::uint16_t port() const;
  // Starts the server thread.
  void start();
  // Runs `fn` on the server thread.
  void post(std::function<void()> fn);
  // Runs `fn` on the server thread every `period`, the first time after one.
  void every(std::chrono::milliseconds period, std::function<void()> fn);
  const WebStats& stats() const;

  struct Impl;  // opaque: the sessions in web_server.cpp use it

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::view
