// Test helper: peis-view's HTTP and WebSocket protocol (view_client.h).
#include "view/view_client.h"

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <stdexcept>

namespace peis::test {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

HttpResult httpGet(std::uint16_t port, const std::string& target, const std::string& host,
                   const std::vector<std::pair<std::string, std::string>>& headers) {
  asio::io_context io;
  beast::tcp_stream stream(io);
  stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  http::request<http::empty_body> request{http::verb::get, target, 11};
  request.set(http::field::host, host);
  request.keep_alive(false);
  for (const auto& [name, value] : headers) request.set(name, value);
  http::write(stream, request);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(64 * 1024 * 1024);
  http::read(stream, buffer, parser);
  const auto& response = parser.get();
  return HttpResult{static_cast<int>(response.result_int()),
                    std::string(response[http::field::content_type]), response.body()};
}

struct ViewSocket::Impl {
  asio::io_context io;
  websocket::stream<beast::tcp_stream> ws{io};
  beast::flat_buffer buffer;
  bool reading = false;
  bool done = false;
  bool closed = false;
  beast::error_code error;
};

ViewSocket::ViewSocket(std::uint16_t port, const std::string& origin, int receiveBuffer)
    : impl_(std::make_unique<Impl>()) {
  auto& socket = beast::get_lowest_layer(impl_->ws).socket();
  socket.open(tcp::v4());
  if (receiveBuffer > 0) socket.set_option(asio::socket_base::receive_buffer_size(receiveBuffer));
  beast::get_lowest_layer(impl_->ws).connect(
      tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  impl_->ws.set_option(websocket::stream_base::decorator([origin](websocket::request_type& req) {
    if (!origin.empty()) req.set(http::field::origin, origin);
  }));
  websocket::response_type response;
  beast::error_code ec;
  impl_->ws.handshake(response, "127.0.0.1:" + std::to_string(port), "/ws", ec);
  if (ec) {
    throw std::runtime_error("WebSocket refused: " + ec.message() + " (HTTP " +
                             std::to_string(response.result_int()) + ": " + response.body() + ")");
  }
  impl_->ws.read_message_max(256 * 1024 * 1024);
}

ViewSocket::~ViewSocket() {
  beast::error_code ignored;
  beast::get_lowest_layer(impl_->ws).socket().close(ignored);
}

void ViewSocket::send(const std::string& text) {
  impl_->ws.text(true);
  impl_->ws.write(asio::buffer(text));
}

void ViewSocket::sendBinary(const std::string& bytes) {
  impl_->ws.binary(true);
  impl_->ws.write(asio::buffer(bytes));
}

std::optional<std::string> ViewSocket::next(std::chrono::milliseconds timeout) {
  if (impl_->closed) return std::nullopt;
  if (!impl_->reading) {
    impl_->reading = true;
    impl_->done = false;
    impl_->ws.async_read(impl_->buffer, [impl = impl_.get()](beast::error_code ec, std::size_t) {
      impl->error = ec;
      impl->done = true;
    });
  }
  impl_->io.restart();
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (!impl_->done && std::chrono::steady_clock::now() < until) {
    impl_->io.run_one_until(until);
  }
  if (!impl_->done) return std::nullopt;
  impl_->reading = false;
  if (impl_->error) {
    impl_->closed = true;
    return std::nullopt;
  }
  std::string message = beast::buffers_to_string(impl_->buffer.data());
  impl_->buffer.consume(impl_->buffer.size());
  return message;
}

bool ViewSocket::closed() const { return impl_->closed; }

int ViewSocket::closeCode() const { return static_cast<int>(impl_->ws.reason().code); }

std::string ViewSocket::closeReason() const {
  return std::string(impl_->ws.reason().reason.c_str());
}

}  // namespace peis::test
