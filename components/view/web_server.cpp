// The view's HTTP and WebSocket server on Boost.Beast (web_server.h).
#include "view/web_server.h"

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <deque>
#include <map>
#include <stdexcept>
#include <thread>

#include "peis/log.h"
#include "view/http_target.h"

namespace peis::view {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

// The sessions hold a plain pointer to the Impl: it outlives them, since
// destroying `io` (declared first, so destroyed last) destroys every
// handler not yet run and with them the sessions they hold.
struct WebServer::Impl {
  asio::io_context io;
  WebLimits limits;
  WebHandlers handlers;
  WebStats stats;
  tcp::acceptor acceptor{io};
  std::thread thread;
  std::uint16_t port = 0;  // the one bound, read from any thread
  std::uint64_t nextClientId = 1;
  // Every open WebSocket client, for the stall check.
  std::map<std::uint64_t, std::weak_ptr<class WsSession>> clients;
  std::vector<std::shared_ptr<struct Ticker>> tickers;

  void accept();
  void checkStalls();
};

// A function run on the server thread every period.
struct Ticker : std::enable_shared_from_this<Ticker> {
  Ticker(asio::io_context& io, std::chrono::milliseconds period, std::function<void()> fn)
      : timer(io), period(period), fn(std::move(fn)) {}
  void schedule() {
    timer.expires_after(period);
    timer.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (ec) return;
      self->fn();
      self->schedule();
    });
  }
  asio::steady_timer timer;
  std::chrono::milliseconds period;
  std::function<void()> fn;
};

namespace {

// A response with the headers every answer of the view carries.
http::response<http::string_body> makeResponse(const HttpReply& reply, unsigned version,
                                               bool keepAlive) {
  http::response<http::string_body> res{static_cast<http::status>(reply.status), version};
  res.set(http::field::server, "peis-view");
  res.set(http::field::content_type, reply.contentType);
  res.set(http::field::cache_control, "no-store");
  res.set("X-Content-Type-Options", "nosniff");
  res.set("Content-Security-Policy",
          "default-src 'self'; img-src 'self' data: blob:; connect-src 'self'; "
          "frame-ancestors 'none'");
  for (const auto& [name, value] : reply.headers) res.set(name, value);
  res.keep_alive(keepAlive);
  res.body() = reply.body;
  res.prepare_payload();
  return res;
}

HttpReply textReply(int status, std::string text) {
  HttpReply reply;
  reply.status = status;
  reply.body = std::move(text) + "\n";
  return reply;
}

}  // namespace

constexpr int kSocketSendBuffer = 256 * 1024;

class WsSession : public WebClient, public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(WebServer::Impl* server, beast::tcp_stream&& stream)
      : server_(server), ws_(std::move(stream)), id_(server_->nextClientId++) {}

  std::uint64_t id() const override { return id_; }
  bool idle() const override { return !writing_ && queue_.empty(); }
  bool closed() const override { return closed_; }

  void run(http::request<http::string_body> request) {
    // A page's socket holds little, so a page that stops reading shows as
    // a stalled write soon, and costs the machine little kernel memory.
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().set_option(
        asio::socket_base::send_buffer_size(kSocketSendBuffer), ignored);
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "peis-view"); }));
    ws_.read_message_max(server_->limits.maxMessageBytes);
    ws_.auto_fragment(false);
    ws_.async_accept(request,
                     [self = shared_from_this()](beast::error_code ec) { self->onAccept(ec); });
  }

  void send(std::string text) override {
    if (closed_) return;
    if (queuedBytes_ + text.size() > server_->limits.maxQueueBytes) {
      ++server_->stats.clientsDroppedQueue;
      drop("its send queue would pass " + std::to_string(server_->limits.maxQueueBytes) + " bytes");
      return;
    }
    queuedBytes_ += text.size();
    queue_.push_back(std::move(text));
    if (!writing_) writeNext();
  }

  // How long the message being written has waited for the client.
  std::chrono::steady_clock::duration stalledFor(std::chrono::steady_clock::time_point now) const {
    return writing_ ? now - writeStarted_ : std::chrono::steady_clock::duration::zero();
  }

  void drop(const std::string& why) {
    if (closed_) return;
    ++server_->stats.clientsDropped;
    log::warn(0, "peis-view: dropped WebSocket client " + std::to_string(id_) + ": " + why);
    end("dropped: " + why);
  }

 private:
  void onAccept(beast::error_code ec) {
    if (ec) {
      closed_ = true;
      return;
    }
    ++server_->stats.clientsOpen;
    ++server_->stats.clientsAccepted;
    opened_ = true;
    server_->clients[id_] = weak_from_this();
    if (server_->handlers.opened) server_->handlers.opened(shared_from_this());
    read();
  }

  void read() {
    if (closed_) return;
    ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      self->onRead(ec);
    });
  }

  void onRead(beast::error_code ec) {
    if (ec) {
      end(ec == websocket::error::closed ? "closed by the page" : ec.message());
      return;
    }
    std::string message = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    const bool binary = !ws_.got_text();
    if (server_->handlers.message)
      server_->handlers.message(shared_from_this(), std::move(message), binary);
    read();
  }

  void writeNext() {
    writing_ = true;
    writeStarted_ = std::chrono::steady_clock::now();
    ws_.text(true);
    ws_.async_write(asio::buffer(queue_.front()),
                    [self = shared_from_this()](beast::error_code ec, std::size_t bytes) {
                      self->onWrite(ec, bytes);
                    });
  }

  void onWrite(beast::error_code ec, std::size_t bytes) {
    writing_ = false;
    if (ec) {
      end(ec.message());
      return;
    }
    ++server_->stats.messagesSent;
    server_->stats.bytesSent += bytes;
    queuedBytes_ -= queue_.front().size();
    queue_.pop_front();
    if (!queue_.empty() && !closed_) writeNext();
  }

  // Ends the connection once: closes the socket (pending reads and writes
  // end with an error) and tells the handler.
  void end(const std::string& why) {
    if (closed_) return;
    closed_ = true;
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
    if (!opened_) return;
    --server_->stats.clientsOpen;
    server_->clients.erase(id_);
    if (server_->handlers.closed) server_->handlers.closed(shared_from_this(), why);
  }

  WebServer::Impl* server_;
  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  std::deque<std::string> queue_;
  std::size_t queuedBytes_ = 0;
  bool writing_ = false;
  bool opened_ = false;
  bool closed_ = false;
  std::chrono::steady_clock::time_point writeStarted_;
  std::uint64_t id_;
};

namespace {

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(WebServer::Impl* server, tcp::socket socket)
      : server_(server), stream_(std::move(socket)) {}

  void run() { read(); }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(16 * 1024);
    parser_->body_limit(16 * 1024);
    stream_.expires_after(server_->limits.requestTimeout);
    http::async_read(
        stream_, buffer_, *parser_,
        [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onRead(ec); });
  }

  void onRead(beast::error_code ec) {
    if (ec == http::error::end_of_stream || ec == beast::error::timeout ||
        ec == asio::error::operation_aborted || ec == asio::error::connection_reset) {
      close();
      return;
    }
    if (ec) {
      ++server_->stats.refusedRequests;
      answer(textReply(400, "bad request: " + ec.message()), 11, false);
      return;
    }
    ++server_->stats.httpRequests;
    auto request = parser_->release();
    const std::string host(request[http::field::host]);
    if (!isLocalHost(host)) {
      ++server_->stats.refusedRequests;
      answer(textReply(403,
                       "this view answers only to localhost, 127.0.0.1 and [::1], not to "
                       "Host '" +
                           host + "'"),
             request.version(), false);
      return;
    }
    const std::string target(request.target());
    const auto question = target.find('?');
    const std::string path = target.substr(0, question);
    const std::string query = question == std::string::npos ? "" : target.substr(question + 1);
    if (websocket::is_upgrade(request)) {
      const std::string origin(request[http::field::origin]);
      if (!isLocalOrigin(origin)) {
        ++server_->stats.refusedRequests;
        answer(textReply(403, "WebSocket from origin '" + origin +
                                  "' refused: only pages of this view may connect"),
               request.version(), false);
        return;
      }
      if (path != "/ws") {
        answer(textReply(404, "WebSocket only on /ws"), request.version(), false);
        return;
      }
      stream_.expires_never();
      std::make_shared<WsSession>(server_, std::move(stream_))->run(std::move(request));
      return;
    }
    if (request.method() != http::verb::get) {
      HttpReply reply = textReply(405, "only GET");
      reply.headers.emplace_back("Allow", "GET");
      answer(reply, request.version(), request.keep_alive());
      return;
    }
    HttpReply reply;
    try {
      reply =
          server_->handlers.get ? server_->handlers.get(path, query) : textReply(404, "not found");
    } catch (const std::exception& e) {
      reply = textReply(500, std::string("internal error: ") + e.what());
    }
    answer(reply, request.version(), request.keep_alive());
  }

  void answer(const HttpReply& reply, unsigned version, bool keepAlive) {
    auto response = std::make_shared<http::response<http::string_body>>(
        makeResponse(reply, version, keepAlive));
    stream_.expires_after(server_->limits.requestTimeout);
    http::async_write(stream_, *response,
                      [self = shared_from_this(), response](beast::error_code ec, std::size_t) {
                        if (ec || !response->keep_alive()) {
                          self->close();
                          return;
                        }
                        self->read();
                      });
  }

  void close() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.socket().close(ignored);
  }

  WebServer::Impl* server_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

}  // namespace

void WebServer::Impl::accept() {
  acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted) return;
    if (!ec) std::make_shared<HttpSession>(this, std::move(socket))->run();
    accept();
  });
}

void WebServer::Impl::checkStalls() {
  const auto now = std::chrono::steady_clock::now();
  std::vector<std::shared_ptr<WsSession>> stalled;
  for (const auto& [id, weak] : clients) {
    auto client = weak.lock();
    if (client && client->stalledFor(now) > limits.stallTimeout) stalled.push_back(client);
  }
  for (const auto& client : stalled) {
    ++stats.clientsDroppedStalled;
    client->drop("it took no message for " + std::to_string(limits.stallTimeout.count()) + " ms");
  }
}

WebServer::WebServer(const std::string& address, std::uint16_t port, WebLimits limits,
                     WebHandlers handlers)
    : impl_(std::make_unique<Impl>()) {
  impl_->limits = limits;
  impl_->handlers = std::move(handlers);
  beast::error_code ec;
  const auto ip = asio::ip::make_address(address, ec);
  if (ec) throw std::runtime_error("'" + address + "' is not an IP address");
  const tcp::endpoint endpoint(ip, port);
  impl_->acceptor.open(endpoint.protocol(), ec);
  if (!ec) impl_->acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) impl_->acceptor.bind(endpoint, ec);
  if (!ec) impl_->acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error("cannot listen on " + address + ":" + std::to_string(port) + ": " +
                             ec.message());
  }
  impl_->port = impl_->acceptor.local_endpoint().port();
}

WebServer::~WebServer() {
  impl_->io.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::uint16_t WebServer::port() const { return impl_->port; }

void WebServer::start() {
  impl_->accept();
  const auto period = std::max(std::chrono::milliseconds(50), impl_->limits.stallTimeout / 4);
  every(period, [impl = impl_.get()] { impl->checkStalls(); });
  impl_->thread = std::thread([impl = impl_.get()] {
    for (;;) {
      try {
        impl->io.run();
        return;
      } catch (const std::exception& e) {
        log::error(0, std::string("peis-view: server thread: ") + e.what());
      }
    }
  });
}

void WebServer::post(std::function<void()> fn) { asio::post(impl_->io, std::move(fn)); }

void WebServer::every(std::chrono::milliseconds period, std::function<void()> fn) {
  auto ticker = std::make_shared<Ticker>(impl_->io, period, std::move(fn));
  impl_->tickers.push_back(ticker);
  asio::post(impl_->io, [ticker] { ticker->schedule(); });
}

const WebStats& WebServer::stats() const { return impl_->stats; }

}  // namespace peis::view
