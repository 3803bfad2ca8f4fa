// Secured test peers; see secured_peer.h.
#include "secured_peer.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include "peis/credentials.h"

namespace peis::test {

TestRoot::TestRoot(const std::string& ecology) : temp_("peis_keys") {
  dir_ = temp_.file("keys");
  createTrustRoot(dir_, ecology);
}

std::string TestRoot::issue(const std::string& principal, std::vector<std::string> groups,
                            std::vector<std::string> names, std::optional<PeisId> pinned) {
  CredentialsRequest request;
  request.principal = principal;
  request.groups = std::move(groups);
  request.names = std::move(names);
  request.pinnedId = pinned;
  return issueCredentials(dir_, request).file;
}

security::Credentials TestRoot::load(const std::string& principal) const {
  return security::readCredentials(dir_ + "/" + principal + ".cred");
}

SecuredRawPeer::SecuredRawPeer(std::uint16_t port, const security::Credentials& credentials,
                               wire::Hello hello, int receiveBuffer)
    : raw_(port, receiveBuffer),
      credentials_(credentials),
      hello_(std::move(hello)),
      handshake_(credentials, true) {
  hello_.auth = handshake_.helloAuth();
  hello_.capabilities |= wire::kCapabilitySecured;
  ownHelloFrame_ = frameOf(wire::LinkMessage{hello_});
}

bool SecuredRawPeer::exchangeHellos() {
  if (!raw_.send(ownHelloFrame_)) return false;
  auto frame = raw_.readFrame(std::chrono::seconds(10));
  if (!frame) return false;
  auto decoded = wire::decode(*frame, 1 << 20);
  if (!decoded.message) return false;
  auto* link = std::get_if<wire::LinkMessage>(&*decoded.message);
  auto* hello = link ? std::get_if<wire::Hello>(link) : nullptr;
  if (!hello) return false;
  targetHello_ = *hello;
  if (handshake_.onPeerHello(hello->auth, ownHelloFrame_.substr(4), *frame)) return false;
  cipher_ = std::make_unique<security::RecordCipher>(handshake_.suite(), handshake_.sendKey(),
                                                     handshake_.receiveKey());
  return true;
}

void SecuredRawPeer::sendAuth() {
  const auto identity =
      security::makeIdentity(credentials_, hello_.id, hello_.incarnation, hello_.name);
  sendAuth(security::encodeIdentity(identity), handshake_.transcriptSignature());
}

void SecuredRawPeer::sendAuth(const std::string& identity, const std::string& signature) {
  send(frameOf(wire::LinkMessage{wire::Auth{identity, signature}}));
}

bool SecuredRawPeer::send(const std::string& frame) { return raw_.send(seal(frame)); }

std::string SecuredRawPeer::seal(const std::string& frame) {
  std::string records;
  cipher_->seal(frame, records);
  return records;
}

std::optional<std::string> SecuredRawPeer::readFrame(std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (true) {
    if (plain_.size() >= 4) {
      const auto length = wire::frameLength(plain_);
      if (plain_.size() >= 4 + length) {
        auto frame = plain_.substr(4, length);
        plain_.erase(0, 4 + length);
        return frame;
      }
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        until - std::chrono::steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    auto body = raw_.readFrame(left);  // a record: length, then ciphertext and tag
    if (!body) return std::nullopt;
    std::string record(4, '\0');
    const auto length = static_cast<std::uint32_t>(body->size());
    for (int i = 0; i < 4; ++i) record[i] = static_cast<char>(length >> (24 - 8 * i));
    record += *body;
    std::size_t whole = 0, plain = 0;
    std::string error, opened(record.size(), '\0');
    if (cipher_->open(record.data(), record.size(), security::RecordCipher::kMaxPlainBytes,
                      opened.data(), whole, plain, error) != security::RecordCipher::Open::Opened) {
      return std::nullopt;
    }
    plain_.append(opened.data(), plain);
  }
}

bool SecuredRawPeer::awaitAuth() {
  while (auto frame = readFrame(std::chrono::seconds(10))) {
    if (!frame->empty() && static_cast<std::uint8_t>((*frame)[0]) ==
                               static_cast<std::uint8_t>(wire::MessageType::Auth)) {
      return true;
    }
  }
  return false;
}

bool SecuredRawPeer::sync() {
  const std::uint64_t nonce = 0x5ec;
  if (!send(frameOf(wire::LinkMessage{wire::Ping{nonce}}))) return false;
  const auto pong = frameOf(wire::LinkMessage{wire::Pong{nonce}}).substr(4);
  while (auto frame = readFrame(std::chrono::seconds(10))) {
    if (*frame == pong) return true;
  }
  return false;
}

TcpTap::TcpTap(std::uint16_t target) : target_(target) {
  listener_ = socket(AF_INET, SOCK_STREAM, 0);
  REQUIRE(listener_ >= 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  REQUIRE(bind(listener_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0);
  REQUIRE(listen(listener_, 4) == 0);
  socklen_t size = sizeof address;
  getsockname(listener_, reinterpret_cast<sockaddr*>(&address), &size);
  port_ = ntohs(address.sin_port);
  thread_ = std::thread([this] { run(); });
}

TcpTap::~TcpTap() {
  stop_ = true;
  thread_.join();
  close(listener_);
}

std::string TcpTap::seen() {
  std::lock_guard lock(mu_);
  return seen_;
}

std::string TcpTap::sentToTarget() {
  std::lock_guard lock(mu_);
  return toTarget_;
}

void TcpTap::setChange(std::function<void(std::string&)> change) {
  std::lock_guard lock(mu_);
  change_ = std::move(change);
}

void TcpTap::run() {
  while (!stop_) {
    pollfd accepting{listener_, POLLIN, 0};
    if (poll(&accepting, 1, 50) <= 0) continue;
    const int from = accept(listener_, nullptr, nullptr);
    if (from < 0) continue;
    const int to = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(target_);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(to, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      close(from);
      close(to);
      continue;
    }
    bool open = true;
    while (open && !stop_) {
      pollfd both[2] = {{from, POLLIN, 0}, {to, POLLIN, 0}};
      if (poll(both, 2, 50) <= 0) continue;
      for (int side = 0; side < 2 && open; ++side) {
        if (!(both[side].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        char buffer[65536];
        const auto n = recv(both[side].fd, buffer, sizeof buffer, 0);
        if (n <= 0) {
          open = false;
          break;
        }
        std::string chunk(buffer, static_cast<std::size_t>(n));
        {
          std::lock_guard lock(mu_);
          if (side == 0 && change_) change_(chunk);
          seen_ += chunk;
          if (side == 0) toTarget_ += chunk;
        }
        const int out = side == 0 ? to : from;
        if (send(out, chunk.data(), chunk.size(), MSG_NOSIGNAL) !=
            static_cast<ssize_t>(chunk.size()))
          open = false;
      }
    }
    close(from);
    close(to);
  }
}

}  // namespace peis::test
