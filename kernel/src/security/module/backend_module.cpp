// The security module (libpeis-security.so): the Backend table over
// libsodium, yaml-cpp and the records' AEAD (libgcrypt and ipsec-mb,
// record_aead.cpp); see backend.h.
// Built as a module that only secured PEIS load (dlopen): nothing but its
// entry point is exported, and no exception leaves it.
#include <sodium.h>
#include <yaml-cpp/yaml.h>

#include <cstring>
#include <exception>

#include "security/backend.h"
#include "security/module/record_aead.h"

namespace peis::security {

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
    module::aeadNew,
    module::aeadName,
    module::aeadFree,
    module::aeadSeal,
    module::aeadOpen,
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
