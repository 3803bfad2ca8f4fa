// Unit tests of the record layer of a secured link (security/record_cipher.h):
// round trips of every size class for both suites, the records byte for byte
// against known answers of the standard AEADs (the wire format of
// docs/protocol.md §15.5), and a changed, replayed, reordered, wrongly
// keyed, oversized or partial record, for every implementation of the
// AEADs in the security module (AES-256-GCM: the faster here, libgcrypt's
// and ipsec-mb's; each other's records open), which the first RecordCipher
// loads (security/backend.h).
#include "security/record_cipher.h"

#include <catch2/catch.hpp>
#include <cstdint>
#include <string>
#include <vector>

using peis::security::AeadImplementation;
using peis::security::CipherSuite;
using peis::security::RecordCipher;

namespace {

const std::string kKeyA(32, '\x11');
const std::string kKeyB(32, '\x22');

std::string pattern(std::size_t bytes) {
  std::string s(bytes, '\0');
  for (std::size_t i = 0; i < bytes; ++i) s[i] = static_cast<char>((i * 131 + 7) & 0xff);
  return s;
}

struct Opened {
  RecordCipher::Open verdict;
  std::string plain;
  std::size_t recordBytes = 0;
};

Opened openOne(RecordCipher& cipher, const std::string& records, std::size_t at = 0,
               std::size_t available = std::string::npos,
               std::size_t most = RecordCipher::kMaxPlainBytes) {
  if (available == std::string::npos) available = records.size() - at;
  Opened r;
  std::string plain(RecordCipher::kMaxPlainBytes, '\0');
  std::size_t plainBytes = 0;
  std::string error;
  r.verdict = cipher.open(records.data() + at, available, most, plain.data(), r.recordBytes,
                          plainBytes, error);
  if (r.verdict == RecordCipher::Open::Opened) r.plain = plain.substr(0, plainBytes);
  if (r.verdict == RecordCipher::Open::Bad) CHECK_FALSE(error.empty());
  return r;
}

// Opens every record of `records` in order; the plaintexts joined.
std::string openAll(RecordCipher& cipher, const std::string& records) {
  std::string plain;
  std::size_t at = 0;
  while (at < records.size()) {
    const auto r = openOne(cipher, records, at);
    REQUIRE(r.verdict == RecordCipher::Open::Opened);
    plain += r.plain;
    at += r.recordBytes;
  }
  return plain;
}

// A suite with one implementation of it.
struct Kind {
  CipherSuite suite;
  AeadImplementation aes;
  std::string name;
};

// ChaCha20-Poly1305, and AES-256-GCM (where the CPU has it) by each
// implementation of this module and CPU: the one records use by default,
// and each by name.
std::vector<Kind> kinds() {
  std::vector<Kind> all{
      {CipherSuite::ChaCha20Poly1305, AeadImplementation::Aes256Gcm,
       "ChaCha20-Poly1305 (" + RecordCipher::implementation(CipherSuite::ChaCha20Poly1305) + ")"}};
  if (!RecordCipher::aesAvailable()) return all;
  for (const auto aes : {AeadImplementation::Aes256Gcm, AeadImplementation::Aes256GcmLibgcrypt,
                         AeadImplementation::Aes256GcmIpsecMb}) {
    const auto name = RecordCipher::implementation(CipherSuite::Aes256Gcm, aes);
    if (!name.empty()) all.push_back({CipherSuite::Aes256Gcm, aes, "AES-256-GCM (" + name + ")"});
  }
  return all;
}

RecordCipher cipherOf(const Kind& kind, const std::string& sendKey, const std::string& receiveKey) {
  return RecordCipher(kind.suite, sendKey, receiveKey, kind.aes);
}

// FNV-1a (64 bits) of the records: a known answer that needs no library.
std::uint64_t fnv1a(const std::string& bytes) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const unsigned char c : bytes) h = (h ^ c) * 0x100000001b3ULL;
  return h;
}

std::string hex(const std::string& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (const unsigned char c : bytes) out += {digits[c >> 4], digits[c & 15]};
  return out;
}

}  // namespace

TEST_CASE("security: record cipher round trips of every size, both suites", "[unit]") {
  for (const auto& kind : kinds()) {
    INFO(kind.name);
    RecordCipher a(kind.suite, kKeyA, kKeyB, kind.aes), b(kind.suite, kKeyB, kKeyA, kind.aes);
    for (std::size_t bytes :
         {1u, 15u, 16u, 17u, 100u, 1024u, 1100u, 4096u, 16383u, 16384u, 16385u, 65536u + 40u}) {
      INFO(bytes << " bytes");
      const auto plain = pattern(bytes);
      std::string records;
      a.seal(plain, records);
      REQUIRE(records.size() == RecordCipher::sealedBytes(bytes));
      CHECK(openAll(b, records) == plain);
      // And back the other way, sealed into a raw buffer.
      std::string raw(RecordCipher::sealedBytes(bytes), '\0');
      REQUIRE(b.seal(plain, raw.data()) == raw.size());
      CHECK(openAll(a, raw) == plain);
    }
  }
}

// A link seals queued frames into blocks of records, cutting the
// plaintext where a block is full: what plainFitting() says fits does.
TEST_CASE("security: the plaintext that fits in a number of record bytes", "[unit]") {
  constexpr auto kWhole = RecordCipher::kMaxPlainBytes + RecordCipher::kOverheadBytes;
  for (std::size_t room : {0u, 1u, 20u, 21u, 1024u, 16403u, 16404u, 16405u, 16425u, 65536u,
                           3 * 16404u + 20u, 3 * 16404u + 21u}) {
    INFO(room << " bytes of records");
    const auto plain = RecordCipher::plainFitting(room);
    if (plain > 0) CHECK(RecordCipher::sealedBytes(plain) <= room);
    CHECK(RecordCipher::sealedBytes(plain + 1) > room);  // and no more
  }
  CHECK(RecordCipher::plainFitting(kWhole) == RecordCipher::kMaxPlainBytes);
  CHECK(RecordCipher::plainFitting(65536) ==
        3 * RecordCipher::kMaxPlainBytes + 65536 - 3 * kWhole - RecordCipher::kOverheadBytes);
}

// The known answers were made with libsodium's crypto_aead_aes256gcm and
// crypto_aead_chacha20poly1305_ietf (an independent implementation), the
// nonce and associated data of §15.5 built by hand; the records of the
// module's OpenSSL (EVP) code that came before matched them too.
TEST_CASE("security: records are the standard AEADs byte for byte (the wire format)", "[unit]") {
  struct Answer {
    std::size_t bytes;
    std::uint64_t fnv;
  };
  for (const auto& kind : kinds()) {
    INFO(kind.name);
    const bool aes = kind.suite == CipherSuite::Aes256Gcm;
    RecordCipher a(kind.suite, kKeyA, kKeyB, kind.aes);
    std::string records;
    a.seal(pattern(16), records);
    CHECK(hex(records) ==
          (aes ? "00000020c34013f7f23984051eb898adf05ceb3b4b71d30e40e333edfb4a28086c85f42d"
               : "00000020a2369a066a0f8ac5d8e06daac181268aac62d5a0b317d005d0f8abbe6d750dec"));
    CHECK(fnv1a(records) == (aes ? 0x676f3c24515c576cULL : 0xacfb96a7d3c6d0daULL));
    // Then records 1 (1 KiB) and 2, 3 (16 KiB and 300 bytes).
    const Answer later[] = {{1024, aes ? 0x99e570bb7618c6a6ULL : 0xeb06196f6e293de0ULL},
                            {16384 + 300, aes ? 0x2ade75552941c943ULL : 0x0495548be82193dcULL}};
    for (const auto& answer : later) {
      INFO(answer.bytes << " bytes");
      records.clear();
      a.seal(pattern(answer.bytes), records);
      CHECK(fnv1a(records) == answer.fnv);
    }
  }
}

// Each implementation of AES-256-GCM opens the others' records, and theirs
// of every size (several records per seal) and direction.
TEST_CASE("security: the implementations of AES-256-GCM open each other's records", "[unit]") {
  std::vector<Kind> aes;
  for (const auto& kind : kinds()) {
    if (kind.suite == CipherSuite::Aes256Gcm) aes.push_back(kind);
  }
  for (const auto& sealer : aes) {
    for (const auto& opener : aes) {
      INFO(sealer.name << " sealed, " << opener.name << " opened");
      RecordCipher a(sealer.suite, kKeyA, kKeyB, sealer.aes),
          b(opener.suite, kKeyB, kKeyA, opener.aes);
      for (std::size_t bytes : {1u, 16u, 1100u, 16384u, 65536u + 40u}) {
        INFO(bytes << " bytes");
        std::string records;
        a.seal(pattern(bytes), records);
        CHECK(openAll(b, records) == pattern(bytes));
        records.clear();
        b.seal(pattern(bytes), records);
        CHECK(openAll(a, records) == pattern(bytes));
      }
      std::string changed;
      a.seal(pattern(100), changed);
      changed[50] = static_cast<char>(changed[50] ^ 0x04);
      CHECK(openOne(b, changed).verdict == RecordCipher::Open::Bad);
    }
  }
}

TEST_CASE("security: a changed, replayed, reordered or wrongly keyed record fails", "[unit]") {
  for (const auto& kind : kinds()) {
    INFO(kind.name);
    RecordCipher a = cipherOf(kind, kKeyA, kKeyB);
    std::string first, second;
    a.seal(pattern(1024), first);
    a.seal(pattern(16), second);

    SECTION("a bit changed in the ciphertext, the tag or the length") {
      for (std::size_t at : {std::size_t{4}, std::size_t{500}, first.size() - 1}) {
        RecordCipher b = cipherOf(kind, kKeyB, kKeyA);
        auto changed = first;
        changed[at] = static_cast<char>(changed[at] ^ 0x01);
        CHECK(openOne(b, changed).verdict == RecordCipher::Open::Bad);
      }
      RecordCipher b = cipherOf(kind, kKeyB, kKeyA);
      auto shorter = first;
      shorter[3] = static_cast<char>(shorter[3] - 1);  // one byte less: the tag moves
      CHECK(openOne(b, shorter).verdict == RecordCipher::Open::Bad);
    }
    SECTION("replayed") {
      RecordCipher b = cipherOf(kind, kKeyB, kKeyA);
      CHECK(openOne(b, first).verdict == RecordCipher::Open::Opened);
      CHECK(openOne(b, first).verdict == RecordCipher::Open::Bad);
    }
    SECTION("reordered") {
      RecordCipher b = cipherOf(kind, kKeyB, kKeyA);
      CHECK(openOne(b, second).verdict == RecordCipher::Open::Bad);
    }
    SECTION("wrongly keyed") {
      RecordCipher b = cipherOf(kind, kKeyB, kKeyB);  // receives under the wrong key
      CHECK(openOne(b, first).verdict == RecordCipher::Open::Bad);
    }
    SECTION("after a good record, the next opens; a failed one is not counted") {
      RecordCipher b = cipherOf(kind, kKeyB, kKeyA);
      auto changed = second;
      changed[8] = static_cast<char>(changed[8] ^ 0x80);
      CHECK(openOne(b, first).verdict == RecordCipher::Open::Opened);
      CHECK(openOne(b, changed).verdict == RecordCipher::Open::Bad);
      const auto r = openOne(b, second);
      CHECK(r.verdict == RecordCipher::Open::Opened);
      CHECK(r.plain == pattern(16));
    }
  }
}

TEST_CASE("security: record lengths: partial, out of range, over the handshake's limit", "[unit]") {
  const auto kind = kinds().back();
  RecordCipher a = cipherOf(kind, kKeyA, kKeyB), b = cipherOf(kind, kKeyB, kKeyA);
  std::string records;
  a.seal(pattern(2000), records);
  CHECK(openOne(b, records, 0, 3).verdict == RecordCipher::Open::NeedMore);
  CHECK(openOne(b, records, 0, records.size() - 1).verdict == RecordCipher::Open::NeedMore);
  CHECK(openOne(b, records, 0, records.size(), 1024).verdict == RecordCipher::Open::Bad);
  std::string empty = records.substr(0, 4 + 16);
  empty[0] = empty[1] = empty[2] = 0;
  empty[3] = 16;  // no plaintext: out of range
  CHECK(openOne(b, empty).verdict == RecordCipher::Open::Bad);
  std::string huge = records;
  huge[0] = 0x7f;
  CHECK(openOne(b, huge).verdict == RecordCipher::Open::Bad);
  const auto r = openOne(b, records);
  CHECK(r.verdict == RecordCipher::Open::Opened);
  CHECK(r.plain == pattern(2000));
}
