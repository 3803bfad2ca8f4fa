// The security layer's use of libsodium (through the security module,
// backend.h), kept to a few named operations so
// that every primitive the platform relies on is listed in one place
// (docs/security.md, "Cryptography"): Ed25519 signatures (the trust root,
// the PEIS keys), X25519 key exchange (crypto_kx for links, static keys for
// the tags of relayed frames), BLAKE2b (transcripts, key derivation, tags).
// The records of a secured link are libgcrypt's or ipsec-mb's AEADs
// (record_cipher.cpp).
// No cryptography of our own: only the composition, which
// docs/protocol.md §15 states.
#pragma once

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>

namespace peis::security {

inline constexpr std::size_t kSignPublicKeyBytes = 32;
inline constexpr std::size_t kSignSecretKeyBytes = 64;
inline constexpr std::size_t kSignatureBytes = 64;
inline constexpr std::size_t kKxPublicKeyBytes = 32;
inline constexpr std::size_t kKxSecretKeyBytes = 32;
inline constexpr std::size_t kKeyBytes = 32;
inline constexpr std::size_t kHashBytes = 32;
inline constexpr std::size_t kTagBytes = 16;

// Loads the security module and initialises libsodium once (thread-safe);
// throws peis::Error(InvalidConfig) if it cannot. Every function below
// does so on its first use: only a secured PEIS loads the module
// (backend.h).
void initCrypto();

struct SignKeyPair {
  std::string publicKey;  // 32 bytes
  std::string secretKey;  // 64 bytes
};
SignKeyPair newSignKeyPair();
std::string sign(std::string_view message, std::string_view secretKey);
bool verify(std::string_view signature, std::string_view message, std::string_view publicKey);
// Whether `secretKey` is the secret half of `publicKey`.
bool keysMatch(std::string_view publicKey, std::string_view secretKey);

// BLAKE2b: an unkeyed 32-byte hash, or a keyed hash of `outBytes`, or
// either of the concatenation of `parts` (`key` empty: unkeyed).
std::string hash(std::string_view message);
std::string hashParts(std::initializer_list<std::string_view> parts, std::size_t outBytes,
                      std::string_view key = {});
std::string keyedHash(std::string_view key, std::string_view message, std::size_t outBytes);
// The first 8 bytes of hash(publicKey) in hex: how keys are shown to people.
std::string fingerprint(std::string_view publicKey);

std::string randomBytes(std::size_t n);
std::uint64_t randomU64();

// Constant-time comparison.
bool sameBytes(std::string_view a, std::string_view b);
// Overwrites a secret with zeros (not optimised away).
void wipe(std::string& secret);

std::string toHex(std::string_view bytes);
std::optional<std::string> fromHex(std::string_view hex);

}  // namespace peis::security
