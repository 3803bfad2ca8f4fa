// RecordCipher: the bytes of a secured link, both ways, as authenticated
// and encrypted records (docs/protocol.md §15.5). This is the link-level
// cipher layer: the Link hands it what it writes and what it reads, and
// nothing else in the kernel sees ciphertext.
//
//   record = u32 length L (17..kMaxPlainBytes + 16) | L − 16 bytes of
//            ciphertext | 16-byte tag
//   AEAD:  AES-256-GCM when both ends have it in hardware, else
//          ChaCha20-Poly1305 (IETF, RFC 8439), in the security module:
//          AES-256-GCM by libgcrypt or ipsec-mb, whichever is faster on
//          this CPU (docs/security.md, "What it costs"), ChaCha20-Poly1305
//          by libgcrypt.
//   nonce: 4 zero bytes | u64 record number (per direction, from 0)
//   associated data: the 4 length bytes
//
// A record out of order, replayed, dropped or changed fails its tag: the
// link is closed. Each direction has its own key (from the handshake).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "security/backend.h"

namespace peis::security {

enum class CipherSuite : std::uint8_t { Aes256Gcm = 1, ChaCha20Poly1305 = 2 };

class RecordCipher {
 public:
  static constexpr std::size_t kHeaderBytes = 4;
  static constexpr std::size_t kTagBytes = 16;
  static constexpr std::size_t kOverheadBytes = kHeaderBytes + kTagBytes;
  // Records of 16 KiB (TLS's size): sealed and opened while in the caches.
  static constexpr std::size_t kMaxPlainBytes = 16 * 1024;

  // Whether this host runs AES-256-GCM in hardware (libsodium's check).
  static bool aesAvailable();

  // `aes`: which code runs AES-256-GCM, by default the faster here (the
  // suite ChaCha20-Poly1305 ignores it); tests name one to compare them.
  RecordCipher(CipherSuite suite, std::string_view sendKey, std::string_view receiveKey,
               AeadImplementation aes = AeadImplementation::Aes256Gcm);
  ~RecordCipher();
  RecordCipher(const RecordCipher&) = delete;
  RecordCipher& operator=(const RecordCipher&) = delete;

  CipherSuite suite() const { return suite_; }
  // The library that seals `suite`'s records in this process (with `aes`
  // for AES-256-GCM); empty when this module or CPU has not that one.
  static std::string implementation(CipherSuite suite,
                                    AeadImplementation aes = AeadImplementation::Aes256Gcm);
  // The size of the records that seal `plainBytes`.
  static std::size_t sealedBytes(std::size_t plainBytes);
  // The most plaintext whose records fit in `recordBytes` (0: none).
  static std::size_t plainFitting(std::size_t recordBytes);

  // Seals `plain` (cut into records of at most kMaxPlainBytes) and appends
  // the records to `out`; the plaintext is read where it is (one pass).
  void seal(std::string_view plain, std::string& out);
  // The same into `out`, which has room for sealedBytes(plain.size())
  // (not overlapping `plain`); returns that many. Nothing is written to
  // `out` but the records (no zero-filling pass before them).
  std::size_t seal(std::string_view plain, char* out);

  // Opens the record at the front of `data` (`available` bytes), writing
  // its plaintext to `plain` (room for the record's length minus 16;
  // not overlapping `data`). NeedMore: not whole yet. Opened: `recordBytes`
  // were its length and `plainBytes` its plaintext. Bad: a length out of
  // range (over `maxPlainBytes`: a link in its handshake takes small ones
  // only) or a failed tag (`error` says which).
  enum class Open { NeedMore, Opened, Bad };
  Open open(const char* data, std::size_t available, std::size_t maxPlainBytes, char* plain,
            std::size_t& recordBytes, std::size_t& plainBytes, std::string& error);
  // The record at the front of `data`: its whole length once its header
  // is there (0: not yet), and its plaintext's.
  static std::size_t recordLength(const char* data, std::size_t available);
  static std::size_t plainLength(std::size_t recordBytes) { return recordBytes - kOverheadBytes; }

 private:
  struct Keys;
  CipherSuite suite_;
  std::unique_ptr<Keys> keys_;
  std::uint64_t sent_ = 0, received_ = 0;
};

}  // namespace peis::security
