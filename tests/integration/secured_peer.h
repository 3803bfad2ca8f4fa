// Test helpers for secured ecologies: a trust root with credentials made in
// a temporary directory; SecuredRawPeer, a hand-driven peer that runs the
// secured handshake (or a forged part of it) and then sends and reads frames
// inside the link's records; and TcpTap, a relay between two PEIS that
// records every byte either way and can change them in flight (what an
// eavesdropper or a man in the middle sees and does).
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "net/wire.h"
#include "raw_peer.h"
#include "security/credentials.h"
#include "security/identity.h"
#include "security/link_handshake.h"
#include "security/record_cipher.h"
#include "support/temp_dir.h"

namespace peis::test {

// A trust root of ecology `ecology` in a temporary directory, and
// credentials issued from it.
class TestRoot {
 public:
  explicit TestRoot(const std::string& ecology);
  // Issues NAME.cred (names: NAME unless `names` says more); returns its path.
  std::string issue(const std::string& principal, std::vector<std::string> groups = {},
                    std::vector<std::string> names = {}, std::optional<PeisId> pinned = {});
  security::Credentials load(const std::string& principal) const;
  const std::string& dir() const { return dir_; }

 private:
  TempDir temp_;
  std::string dir_;
};

class SecuredRawPeer {
 public:
  // Connects to 127.0.0.1:port as the holder of `credentials`, claiming
  // `hello` (its auth is filled in); `receiveBuffer` as RawPeer's.
  SecuredRawPeer(std::uint16_t port, const security::Credentials& credentials, wire::Hello hello,
                 int receiveBuffer = 0);

  // Sends our Hello, reads the target's and derives the keys; false if the
  // target closed the link instead.
  bool exchangeHellos();
  // Sends our Auth: our identity and signature, or the ones given (forged,
  // replayed).
  void sendAuth();
  void sendAuth(const std::string& identity, const std::string& signature);
  // Sends one whole frame inside a record.
  bool send(const std::string& frame);
  // The record that would carry `frame` (sealed now: the next one sent),
  // and bytes sent as they are.
  std::string seal(const std::string& frame);
  bool sendRaw(const std::string& bytes) { return raw_.send(bytes); }
  const security::LinkHandshake& handshake() const { return handshake_; }
  // The next whole frame (type and body), opened from the records.
  std::optional<std::string> readFrame(std::chrono::milliseconds timeout);
  bool closedByPeer() { return raw_.closedByPeer(); }
  // Reads until the target's Auth has come and been checked by us.
  bool awaitAuth();
  // Ping, then read until its Pong: everything sent before was handled.
  bool sync();
  const wire::Hello& targetHello() const { return targetHello_; }

 private:
  RawPeer raw_;
  const security::Credentials& credentials_;
  wire::Hello hello_;
  std::string ownHelloFrame_;
  wire::Hello targetHello_;
  security::LinkHandshake handshake_;
  std::unique_ptr<security::RecordCipher> cipher_;
  std::string plain_;
};

// A TCP relay on a port of its own to 127.0.0.1:`target`, one connection
// at a time; `change` may alter each chunk in flight (from dialler to target).
class TcpTap {
 public:
  explicit TcpTap(std::uint16_t target);
  ~TcpTap();
  std::uint16_t port() const { return port_; }
  // Everything that passed, either way, so far.
  std::string seen();
  // The bytes from the dialler to the target, so far.
  std::string sentToTarget();
  void setChange(std::function<void(std::string& chunk)> change);

 private:
  void run();
  std::uint16_t target_;
  std::uint16_t port_ = 0;
  int listener_ = -1;
  std::atomic<bool> stop_{false};
  std::mutex mu_;
  std::string seen_, toTarget_;
  std::function<void(std::string&)> change_;
  std::thread thread_;
};

}  // namespace peis::test
