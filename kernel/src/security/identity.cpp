// Identities: bytes, signatures, checks, the book; see identity.h.
#include "security/identity.h"

#include "security/bytes.h"
#include "security/crypto.h"

namespace peis::security {

namespace {

constexpr std::string_view kBindingContext = "PEIS v3 identity";

std::string bindingBytes(const Identity& i) {
  ByteWriter w;
  w.raw(kBindingContext);
  w.str8(i.certificate.ecology);
  w.raw(i.certificate.publicKey);
  w.u32(static_cast<std::uint32_t>(i.id));
  w.u64(i.incarnation);
  w.str8(i.name);
  return w.take();
}

}  // namespace

Identity makeIdentity(const Credentials& credentials, PeisId id, std::uint64_t incarnation,
                      const std::string& name) {
  Identity i;
  i.certificate = credentials.certificate;
  i.id = id;
  i.incarnation = incarnation;
  i.name = name;
  i.signature = sign(bindingBytes(i), credentials.secretKey);
  return i;
}

std::string encodeIdentity(const Identity& i) {
  ByteWriter w;
  w.raw(encodeCertificate(i.certificate));
  w.u32(static_cast<std::uint32_t>(i.id));
  w.u64(i.incarnation);
  w.str8(i.name);
  w.raw(i.signature);
  return w.take();
}

std::optional<Identity> decodeIdentity(std::string_view& in, std::string& error) {
  auto certificate = decodeCertificate(in, error);
  if (!certificate) return std::nullopt;
  ByteReader r(in);
  Identity i;
  i.certificate = std::move(*certificate);
  const auto id = static_cast<std::int32_t>(r.u32());
  i.incarnation = r.u64();
  i.name = r.str8();
  i.signature = std::string(r.raw(kSignatureBytes));
  if (!r.ok()) {
    error = "truncated identity";
    return std::nullopt;
  }
  if (!isValidPeisId(id)) {
    error = "identity with an invalid id";
    return std::nullopt;
  }
  i.id = id;
  in.remove_prefix(r.position());
  return i;
}

std::optional<std::string> identityProblem(const Identity& i, const TrustAnchor& anchor,
                                           std::int64_t now) {
  if (auto problem = certificateProblem(i.certificate, anchor.rootKey, anchor.ecology, now)) {
    return problem;
  }
  if (!allowsName(i.certificate, i.name)) {
    return "its certificate (" + describe(i.certificate) + ") does not allow the name '" + i.name +
           "'";
  }
  if (i.certificate.pinnedId != 0 && i.certificate.pinnedId != i.id) {
    return "its certificate pins id " + std::to_string(i.certificate.pinnedId) + ", not " +
           std::to_string(i.id);
  }
  if (!verify(i.signature, bindingBytes(i), i.certificate.publicKey)) {
    return "its id, incarnation and name are not signed by its certificate's key";
  }
  return std::nullopt;
}

bool IdentityBook::put(Identity identity) {
  auto [it, added] = book_.try_emplace(identity.id, identity);
  if (added) return true;
  if (identity.incarnation < it->second.incarnation) return false;
  it->second = std::move(identity);
  return true;
}

const Identity* IdentityBook::find(PeisId id) const {
  const auto it = book_.find(id);
  return it == book_.end() ? nullptr : &it->second;
}

bool IdentityBook::vouches(PeisId id, std::uint64_t incarnation, std::string_view name) const {
  const auto* i = find(id);
  return i && i->incarnation == incarnation && i->name == name;
}

}  // namespace peis::security
