// LinkHandshake: the cryptography of setting up one secured link
// (docs/protocol.md §15.4), as pure steps the Network runs:
//  1. each end puts helloAuth() in its Hello: an ephemeral X25519 key, the
//     cipher suites it runs and its trust root's id;
//  2. with both Hellos (the exact bytes), each end derives the link's
//     record keys (crypto_kx, then bound to the transcript, the hash of
//     both Hellos) and switches its link to records;
//  3. each end sends, as its first record, an Auth: its identity (its
//     certificate and its signed id, incarnation and name) and its
//     signature over the transcript; the other end checks both.
// A recorded Auth is useless on another link (the transcript holds both
// ends' fresh ephemeral keys), so the handshake cannot be replayed.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "security/credentials.h"
#include "security/identity.h"
#include "security/record_cipher.h"

namespace peis::security {

// What a secured PEIS's Hello carries in its auth field.
struct HelloAuth {
  std::uint8_t suites = 0;   // bit 0: AES-256-GCM in hardware; bit 1: ChaCha20-Poly1305
  std::string ephemeralKey;  // X25519, 32 bytes
  std::string rootId;        // the first 16 bytes of BLAKE2b(root public key)
};
std::string encodeHelloAuth(const HelloAuth& auth);
std::optional<HelloAuth> decodeHelloAuth(std::string_view bytes, std::string& error);
// The id of a trust root as it appears in HelloAuth.
std::string rootIdOf(std::string_view rootKey);

class LinkHandshake {
 public:
  // `dialer`: this end opened the TCP connection (crypto_kx's client).
  LinkHandshake(const Credentials& credentials, bool dialer);
  ~LinkHandshake();
  LinkHandshake(const LinkHandshake&) = delete;
  LinkHandshake& operator=(const LinkHandshake&) = delete;

  // The auth field of our Hello.
  std::string helloAuth() const;
  // The peer's Hello arrived: `ourHello` and `peerHello` are both frames'
  // bytes after the length field. Derives the keys; the reason when the
  // peer's auth is malformed or names another trust root.
  std::optional<std::string> onPeerHello(std::string_view peerAuth, std::string_view ourHello,
                                         std::string_view peerHello);
  CipherSuite suite() const { return suite_; }
  const std::string& sendKey() const { return sendKey_; }
  const std::string& receiveKey() const { return receiveKey_; }

  // Our signature over the transcript (for our Auth).
  std::string transcriptSignature() const;
  // Checks the peer's Auth: its identity under `anchor` at `now`, bound to
  // what its Hello said (id, incarnation, name), and its signature over the
  // transcript by the identity's key. The identity, or why not.
  std::variant<Identity, std::string> checkAuth(std::string_view identityBytes,
                                                std::string_view signature, PeisId helloId,
                                                std::uint64_t helloIncarnation,
                                                std::string_view helloName,
                                                const TrustAnchor& anchor, std::int64_t now) const;

 private:
  std::string signedTranscript(bool byDialer) const;

  const Credentials& credentials_;
  bool dialer_;
  std::string ephemeralPublic_, ephemeralSecret_;
  std::string transcript_;  // BLAKE2b(dialer's Hello | acceptor's Hello)
  CipherSuite suite_ = CipherSuite::ChaCha20Poly1305;
  std::string sendKey_, receiveKey_;
};

}  // namespace peis::security
