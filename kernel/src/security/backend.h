// Backend: what the security layer takes from libsodium, libgcrypt, ipsec-mb and
// yaml-cpp, as a table of functions that the security module
// (libpeis-security.so, backend_module.cpp) fills in. The kernel loads that
// module with dlopen the first time a secured ecology (or `peis keys`)
// needs one of them (backend(), backend_loader.cpp), so a PEIS of an open
// ecology never maps those libraries nor initialises them
// (docs/security.md, "The security module"; docs/performance.md,
// "Memory per PEIS").
//
// Only this header (and yaml_node.h) is shared by the kernel and the
// module; it names no type of the libraries. Every function returns its
// error instead of throwing (no exception crosses the module's boundary).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "security/yaml_node.h"

namespace peis::security {

// Bumped whenever the table or the meaning of an entry changes: a kernel
// takes a module only of its own version and revision (and table size).
inline constexpr std::uint32_t kBackendRevision = 2;

// One direction of a link's records: an AEAD keyed once (a libgcrypt
// cipher handle, or ipsec-mb's expanded AES-GCM keys).
struct AeadContext;

// The code that runs a link's records. AES-256-GCM has two in the module
// (the same bytes on the wire): libgcrypt's and, on x86-64 builds, Intel's
// ipsec-mb (AVX-512 VAES code); `Aes256Gcm` is whichever sealed faster on
// this CPU when the module first measured them (module/record_aead.cpp),
// unless $PEIS_RECORD_AEAD names one. Tests name them to compare them.
enum class AeadImplementation : std::uint8_t {
  Aes256Gcm,
  Aes256GcmLibgcrypt,
  Aes256GcmIpsecMb,
  ChaCha20Poly1305,  // libgcrypt's
};

struct Backend {
  std::uint32_t revision;
  std::uint32_t size;  // sizeof(Backend)

  // libsodium: sodium_init (0 on success).
  int (*init)();
  // Ed25519.
  void (*signKeyPair)(unsigned char* publicKey, unsigned char* secretKey);
  void (*sign)(unsigned char* signature, const unsigned char* message, std::size_t bytes,
               const unsigned char* secretKey);
  bool (*verify)(const unsigned char* signature, const unsigned char* message, std::size_t bytes,
                 const unsigned char* publicKey);
  void (*secretToPublic)(unsigned char* publicKey, const unsigned char* secretKey);
  // Ed25519 keys as X25519 keys (false: not a valid point), and X25519.
  void (*secretToCurve)(unsigned char* curveSecret, const unsigned char* secretKey);
  bool (*publicToCurve)(unsigned char* curvePublic, const unsigned char* publicKey);
  bool (*scalarMult)(unsigned char* shared, const unsigned char* secret,
                     const unsigned char* otherPublic);
  // crypto_kx: a key pair, and a client's or server's session keys
  // (false: the peer's key is unusable).
  void (*kxKeyPair)(unsigned char* publicKey, unsigned char* secretKey);
  bool (*kxSessionKeys)(bool client, unsigned char* receiveKey, unsigned char* sendKey,
                        const unsigned char* ourPublic, const unsigned char* ourSecret,
                        const unsigned char* theirPublic);
  // BLAKE2b of the concatenation of `parts`, keyed by `key` (empty: none),
  // `outBytes` long (16..64).
  void (*hash)(unsigned char* out, std::size_t outBytes, const std::string_view* parts,
               std::size_t partCount, std::string_view key);
  void (*randomBytes)(void* out, std::size_t bytes);
  bool (*sameBytes)(const void* a, const void* b, std::size_t bytes);  // constant time
  void (*wipe)(void* data, std::size_t bytes);
  bool (*aesAvailable)();  // AES-NI and CLMUL (libsodium's check)

  // The records' AEAD (libgcrypt is initialised, and the implementations
  // of AES-256-GCM compared, on the first call): `implementation` keyed by
  // the 32-byte `key`, to seal or to open; nullptr on failure or when this
  // module or CPU has not that implementation. Freed (and wiped) by
  // aeadFree.
  AeadContext* (*aeadNew)(AeadImplementation implementation, const unsigned char* key);
  // The library that runs `implementation` here ("libgcrypt", "ipsec-mb
  // (AVX-512, VAES)"), or nullptr when it is not in this module or CPU.
  const char* (*aeadName)(AeadImplementation implementation);
  void (*aeadFree)(AeadContext* context);
  // One record: `text` (`bytes`) under the 12-byte nonce and the associated
  // data `ad`; sealing writes the ciphertext to `out` and the 16-byte tag
  // to `tag`, opening the plaintext to `out` when `tag` checks.
  bool (*aeadSeal)(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
                   std::size_t adBytes, const unsigned char* text, std::size_t bytes,
                   unsigned char* out, unsigned char* tag);
  bool (*aeadOpen)(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
                   std::size_t adBytes, const unsigned char* text, std::size_t bytes,
                   unsigned char* out, unsigned char* tag);

  // yaml-cpp: parses `text` into `root`; false with the 0-based line
  // (-1: unknown) and the message when it is not YAML.
  bool (*parseYaml)(std::string_view text, YamlNode& root, int& errorLine, std::string& error);
};

// The module's entry point, looked up by name: its table when `version`
// (the project's) and `revision` are its own, else nullptr.
using BackendEntry = const Backend* (*)(const char* version, std::uint32_t revision);
inline constexpr const char* kBackendEntryName = "peis_security_backend";

// The table, loading the module on first use (thread-safe). Throws
// peis::Error(InvalidConfig) naming the places searched when no module of
// this kernel's version is found.
const Backend& backend();
// Whether the module is loaded in this process (for tests and `peis info`).
bool backendLoaded();

}  // namespace peis::security
