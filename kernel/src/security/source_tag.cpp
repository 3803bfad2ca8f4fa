// Tags of relayed frames; see source_tag.h.
#include "security/source_tag.h"

#include <sodium.h>

#include "security/crypto.h"

namespace peis::security {

namespace {

constexpr std::string_view kContext = "PEIS v3 source tags";
// Frame bytes after the length field: u8 type | i32 source | i32
// destination | u8 ttl | body.
constexpr std::size_t kTtlOffset = 9;
// Pair keys kept; beyond, the cache starts over (an ecology of this many
// PEIS that all talk over relays is far beyond the routing table's size).
constexpr std::size_t kMaxPairKeys = 8192;

const unsigned char* u(std::string_view s) {
  return reinterpret_cast<const unsigned char*>(s.data());
}
unsigned char* u(std::string& s) { return reinterpret_cast<unsigned char*>(s.data()); }

}  // namespace

SourceTags::SourceTags(const Credentials& ours)
    : ourKey_(ours.certificate.publicKey), ourCurve_(crypto_scalarmult_curve25519_BYTES, '\0') {
  initCrypto();
  crypto_sign_ed25519_sk_to_curve25519(u(ourCurve_), u(ours.secretKey));
}

SourceTags::~SourceTags() {
  sodium_memzero(ourCurve_.data(), ourCurve_.size());
  for (auto& [k, v] : pairKeys_) sodium_memzero(v.data(), v.size());
}

const std::string& SourceTags::pairKey(std::string_view theirKey) {
  if (auto it = pairKeys_.find(theirKey); it != pairKeys_.end()) return it->second;
  if (pairKeys_.size() >= kMaxPairKeys) pairKeys_.clear();
  std::string theirCurve(crypto_scalarmult_curve25519_BYTES, '\0');
  std::string shared(crypto_scalarmult_BYTES, '\0');
  std::string key;
  if (theirKey.size() == crypto_sign_PUBLICKEYBYTES &&
      crypto_sign_ed25519_pk_to_curve25519(u(theirCurve), u(theirKey)) == 0 &&
      crypto_scalarmult(u(shared), u(ourCurve_), u(theirCurve)) == 0) {
    const bool oursFirst = std::string_view(ourKey_) < theirKey;
    key = hash(std::string(kContext) + shared + (oursFirst ? ourKey_ : std::string(theirKey)) +
               (oursFirst ? std::string(theirKey) : ourKey_));
  } else {
    key = randomBytes(kKeyBytes);  // an unusable key: no tag will ever check
  }
  sodium_memzero(shared.data(), shared.size());
  return pairKeys_.emplace(std::string(theirKey), std::move(key)).first->second;
}

std::string SourceTags::tag(std::string_view theirKey, std::string_view frame,
                            std::string_view tail) {
  const auto& key = pairKey(theirKey);
  crypto_generichash_state state;
  crypto_generichash_init(&state, u(key), key.size(), kTagBytes);
  if (frame.size() > kTtlOffset) {
    crypto_generichash_update(&state, u(frame), kTtlOffset);
    crypto_generichash_update(&state, u(frame.substr(kTtlOffset + 1)),
                              frame.size() - kTtlOffset - 1);
  }
  crypto_generichash_update(&state, u(tail), tail.size());
  std::string out(kTagBytes, '\0');
  crypto_generichash_final(&state, u(out), out.size());
  return out;
}

bool SourceTags::check(std::string_view theirKey, std::string_view tagBytes,
                       std::string_view frame) {
  return tagBytes.size() == kTagBytes && sameBytes(tag(theirKey, frame), tagBytes);
}

}  // namespace peis::security
