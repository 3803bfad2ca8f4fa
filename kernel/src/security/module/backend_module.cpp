// The security module (libpeis-security.so): the Backend table over
// libsodium, OpenSSL's libcrypto and yaml-cpp; see backend.h. Built as a
// module that only secured PEIS load (dlopen): nothing but its entry point
// is exported, and no exception leaves it.
#include <openssl/core_names.h>
#include <openssl/evp.h>
#include <openssl/params.h>
#include <sodium.h>
#include <yaml-cpp/yaml.h>

#include <cstring>
#include <exception>

#include "security/backend.h"

namespace peis::security {

struct AeadContext {
  EVP_CIPHER_CTX* ctx = nullptr;
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

AeadContext* aeadNew(bool aes, const unsigned char* key, bool seal) {
  EVP_CIPHER_CTX* ctx = EVP_CIPHER_CTX_new();
  const EVP_CIPHER* cipher = aes ? EVP_aes_256_gcm() : EVP_chacha20_poly1305();
  const bool ok =
      ctx != nullptr && (seal ? EVP_EncryptInit_ex(ctx, cipher, nullptr, key, nullptr)
                              : EVP_DecryptInit_ex(ctx, cipher, nullptr, key, nullptr)) == 1;
  if (!ok) {
    EVP_CIPHER_CTX_free(ctx);
    return nullptr;
  }
  return new (std::nothrow) AeadContext{ctx};
}

void aeadFree(AeadContext* context) {
  if (context == nullptr) return;
  EVP_CIPHER_CTX_free(context->ctx);  // frees the expanded keys (cleansed)
  delete context;
}

// The tag, read and set through the cipher's parameters (what
// EVP_CIPHER_CTX_ctrl's EVP_CTRL_AEAD_GET_TAG and _SET_TAG translate to in
// OpenSSL 3, without the translation each record): the same parameter for
// both AEADs.
bool tagParam(EVP_CIPHER_CTX* ctx, unsigned char* tag, bool get) {
  OSSL_PARAM params[] = {OSSL_PARAM_construct_octet_string(OSSL_CIPHER_PARAM_AEAD_TAG, tag, 16),
                         OSSL_PARAM_construct_end()};
  return (get ? EVP_CIPHER_CTX_get_params(ctx, params) : EVP_CIPHER_CTX_set_params(ctx, params)) ==
         1;
}

bool aeadSeal(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
              std::size_t adBytes, const unsigned char* text, std::size_t bytes, unsigned char* out,
              unsigned char* tag) {
  auto* ctx = context->ctx;
  int written = 0, last = 0;
  return EVP_EncryptInit_ex(ctx, nullptr, nullptr, nullptr, nonce) == 1 &&
         EVP_EncryptUpdate(ctx, nullptr, &written, ad, static_cast<int>(adBytes)) == 1 &&
         EVP_EncryptUpdate(ctx, out, &written, text, static_cast<int>(bytes)) == 1 &&
         EVP_EncryptFinal_ex(ctx, out + written, &last) == 1 && tagParam(ctx, tag, true);
}

bool aeadOpen(AeadContext* context, const unsigned char* nonce, const unsigned char* ad,
              std::size_t adBytes, const unsigned char* text, std::size_t bytes, unsigned char* out,
              unsigned char* tag) {
  auto* ctx = context->ctx;
  int written = 0, last = 0;
  return EVP_DecryptInit_ex(ctx, nullptr, nullptr, nullptr, nonce) == 1 &&
         EVP_DecryptUpdate(ctx, nullptr, &written, ad, static_cast<int>(adBytes)) == 1 &&
         EVP_DecryptUpdate(ctx, out, &written, text, static_cast<int>(bytes)) == 1 &&
         tagParam(ctx, tag, false) && EVP_DecryptFinal_ex(ctx, out + written, &last) == 1;
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
