// The security module (libpeis-security.so): the Backend table over
// libsodium, libgcrypt (the records' AEAD) and yaml-cpp; see backend.h.
// Built as a module that only secured PEIS load (dlopen): nothing but its
// entry point is exported, and no exception leaves it.
#include <gcrypt.h>
#include <sodium.h>
#include <yaml-cpp/yaml.h>

#include <cstring>
#include <exception>
#include <new>

#include "security/backend.h"

namespace peis::security {

// A libgcrypt handle, keyed once; each record sets its nonce. Closing it
// wipes the expanded key.
struct AeadContext {
  gcry_cipher_hd_t handle = nullptr;
};

namespace {

int init() { return sodium_init() < 0 ? -1 : 0; }

void signKeyPair(unsigned char* pk, unsigned char* sk) { crypto_sign_keypair(pk, sk); }

void sign(unsigned char* signature, const unsigned char* message, std::size_t bytes,
          const unsigned char* sk) {
  crypto_sign_detached(signature, nullptr, message, bytes, sk);
}

bool verify(const unsigned char* signature, const unsigned char* message, std::size_t bytes,
            const unsigned char* pk) {
  return crypto_sign_verify_detached(signature, message, bytes, pk) == 0;
}

void secretToPublic(unsigned char* pk, const unsigned char* sk) {
  crypto_sign_ed25519_sk_to_pk(pk, sk);
}

void secretToCurve(unsigned char* curve, const unsigned char* sk) {
  crypto_sign_ed25519_sk_to_curve25519(curve, sk);
}

bool publicToCurve(unsigned char* curve, const unsigned char* pk) {
  return crypto_sign_ed25519_pk_to_curve25519(curve, pk) == 0;
}

bool scalarMult(unsigned char* shared, const unsigned char* secret, const unsigned char* other) {
  return crypto_scalarmult(shared, secret, other) == 0;
}

void kxKeyPair(unsigned char* pk, unsigned char* sk) { crypto_kx_keypair(pk, sk); }

bool kxSessionKeys(bool client, unsigned char* rx, unsigned char* tx, const unsigned char* ourPk,
                   const unsigned char* ourSk, const unsigned char* theirPk) {
  return (client ? crypto_kx_client_session_keys(rx, tx, ourPk, ourSk, theirPk)
                 : crypto_kx_server_session_keys(rx, tx, ourPk, ourSk, theirPk)) == 0;
}

void hash(unsigned char* out, std::size_t outBytes, const std::string_view* parts,
          std::size_t count, std::string_view key) {
  crypto_generichash_state state;
  crypto_generichash_init(&state, reinterpret_cast<const unsigned char*>(key.data()), key.size(),
                          outBytes);
  for (std::size_t i = 0; i < count; ++i) {
    crypto_generichash_update(&state, reinterpret_cast<const unsigned char*>(parts[i].data()),
                              parts[i].size());
  }
  crypto_generichash_final(&state, out, outBytes);
}

void randomBytes(void* out, std::size_t bytes) { randombytes_buf(out, bytes); }

bool sameBytes(const void* a, const void* b, std::size_t bytes) {
  return sodium_memcmp(a, b, bytes) == 0;
}

void wipe(void* data, std::size_t bytes) { sodium_memzero(data, bytes); }

bool aesAvailable() { return crypto_aead_aes256gcm_is_available() != 0; }

// libgcrypt is initialised once per process, on the first AEAD (a
// function-local static: thread-safe), unless the program did it first; a
// PEIS that only signs (`peis keys`) never does. No secure memory: the keys
// live in ordinary memory, as libsodium's do, and are wiped on close.
bool gcryptReady() {
  static const bool ready = [] {
    if (gcry_control(GCRYCTL_INITIALIZATION_FINISHED_P) != 0) return true;
    if (gcry_check_version(GCRYPT_VERSION) == nullptr) return false;  // older than the headers
    gcry_control(GCRYCTL_DISABLE_SECMEM, 0);
    gcry_control(GCRYCTL_INITIALIZATION_FINISHED, 0);
    return true;
  }();
  return ready;
}

// One handle serves both directions in libgcrypt: `seal` is not needed.
AeadContext* aeadNew(bool aes, const unsigned char* key, bool /*seal*/) {
  if (!gcryptReady()) return nullptr;
  gcry_cipher_hd_t handle = nullptr;
  const bool ok =
      gcry_cipher_open(&handle, aes ? GCRY_CIPHER_AES256 : GCRY_CIPHER_CHACHA20,
                       aes ? GCRY_CIPHER_MODE_GCM : GCRY_CIPHER_MODE_POLY1305, 0) == 0 &&
      gcry_cipher_setkey(handle, key, 32) == 0;
  auto* context = ok ? new (std::nothrow) AeadContext{handle} : nullptr;
  if (context == nullptr) gcry_cipher_close(handle);  // nullptr: nothing
  return context;
}

void aeadFree(AeadContext* context) {
  if (context == nullptr) return;
  gcry_cipher_close(context->handle);  // wipes the expanded key
  delete context;
}

bool aeadSeal(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
              std::size_t adBytes, const unsigned char* text, std::size_t bytes, unsigned char* out,
              unsigned char* tag) {
  auto* handle = context->handle;
  return gcry_cipher_setiv(handle, nonce, 12) == 0 &&
         gcry_cipher_authenticate(handle, ad, adBytes) == 0 &&
         gcry_cipher_encrypt(handle, out, bytes, text, bytes) == 0 &&
         gcry_cipher_gettag(handle, tag, 16) == 0;
}

// The tag is checked in constant time; a failed one leaves `out` written
// but not to be taken (the link closes).
bool aeadOpen(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
              std::size_t adBytes, const unsigned char* text, std::size_t bytes, unsigned char* out,
              unsigned char* tag) {
  auto* handle = context->handle;
  return gcry_cipher_setiv(handle, nonce, 12) == 0 &&
         gcry_cipher_authenticate(handle, ad, adBytes) == 0 &&
         gcry_cipher_decrypt(handle, out, bytes, text, bytes) == 0 &&
         gcry_cipher_checktag(handle, tag, 16) == 0;
}

YamlNode convert(const YAML::Node& node) {
  YamlNode out;
  out.line = node.Mark().line;
  switch (node.Type()) {
    case YAML::NodeType::Undefined:
      out.kind = YamlNode::Kind::Undefined;
      break;
    case YAML::NodeType::Null:
      out.kind = YamlNode::Kind::Null;
      break;
    case YAML::NodeType::Scalar:
      out.kind = YamlNode::Kind::Scalar;
      out.scalar = node.Scalar();
      break;
    case YAML::NodeType::Sequence:
      out.kind = YamlNode::Kind::Sequence;
      for (const auto& item : node) out.items.push_back(convert(item));
      break;
    case YAML::NodeType::Map:
      out.kind = YamlNode::Kind::Map;
      for (const auto& entry : node) {
        out.keys.push_back(convert(entry.first));
        out.items.push_back(convert(entry.second));
      }
      break;
  }
  return out;
}

bool parseYaml(std::string_view text, YamlNode& root, int& errorLine, std::string& error) {
  try {
    root = convert(YAML::Load(std::string(text)));
    return true;
  } catch (const YAML::Exception& e) {
    errorLine = e.mark.line;
    error = e.msg;
  } catch (const std::exception& e) {
    errorLine = -1;
    error = e.what();
  }
  return false;
}

constexpr Backend kBackend{
    kBackendRevision,
    sizeof(Backend),
    init,
    signKeyPair,
    sign,
    verify,
    secretToPublic,
    secretToCurve,
    publicToCurve,
    scalarMult,
    kxKeyPair,
    kxSessionKeys,
    hash,
    randomBytes,
    sameBytes,
    wipe,
    aesAvailable,
    aeadNew,
    aeadFree,
    aeadSeal,
    aeadOpen,
    parseYaml,
};

}  // namespace
}  // namespace peis::security

extern "C" __attribute__((visibility("default"))) const peis::security::Backend*
peis_security_backend(const char* version, std::uint32_t revision) {
  if (version == nullptr || std::strcmp(version, PEIS_VERSION) != 0 ||
      revision != peis::security::kBackendRevision) {
    return nullptr;
  }
  return &peis::security::kBackend;
}
