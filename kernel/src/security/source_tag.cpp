// Tags of relayed frames; see source_tag.h.
#include "security/source_tag.h"

#include "security/backend.h"
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
    : ourKey_(ours.certificate.publicKey), ourCurve_(kKxSecretKeyBytes, '\0') {
  backend().secretToCurve(u(ourCurve_), u(ours.secretKey));
}

SourceTags::~SourceTags() {
  wipe(ourCurve_);
  for (auto& [k, v] : pairKeys_) wipe(v);
}

const std::string& SourceTags::pairKey(std::string_view theirKey) {
  if (auto it = pairKeys_.find(theirKey); it != pairKeys_.end()) return it->second;
  if (pairKeys_.size() >= kMaxPairKeys) pairKeys_.clear();
  std::string theirCurve(kKxPublicKeyBytes, '\0');
  std::string shared(kKeyBytes, '\0');
  std::string key;
  if (theirKey.size() == kSignPublicKeyBytes &&
      backend().publicToCurve(u(theirCurve), u(theirKey)) &&
      backend().scalarMult(u(shared), u(ourCurve_), u(theirCurve))) {
    const bool oursFirst = std::string_view(ourKey_) < theirKey;
    key = hash(std::string(kContext) + shared + (oursFirst ? ourKey_ : std::string(theirKey)) +
               (oursFirst ? std::string(theirKey) : ourKey_));
  } else {
    key = randomBytes(kKeyBytes);  // an unusable key: no tag will ever check
  }
  wipe(shared);
  return pairKeys_.emplace(std::string(theirKey), std::move(key)).first->second;
}

std::string SourceTags::tag(std::string_view theirKey, std::string_view frame,
                            std::string_view tail) {
  const auto& key = pairKey(theirKey);
  if (frame.size() > kTtlOffset) {
    return hashParts({frame.substr(0, kTtlOffset), frame.substr(kTtlOffset + 1), tail}, kTagBytes,
                     key);
  }
  return hashParts({tail}, kTagBytes, key);
}

bool SourceTags::check(std::string_view theirKey, std::string_view tagBytes,
                       std::string_view frame) {
  return tagBytes.size() == kTagBytes && sameBytes(tag(theirKey, frame), tagBytes);
}

}  // namespace peis::security
