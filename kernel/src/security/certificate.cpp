// Certificates: bytes, signatures, checks; see certificate.h.
#include "security/certificate.h"

#include <cstdio>

#include "security/bytes.h"
#include "security/crypto.h"

namespace peis::security {

namespace {

constexpr std::uint8_t kCertificateVersion = 1;
constexpr std::string_view kCertificateContext = "PEIS v3 certificate";

}  // namespace

std::string certificateBody(const Certificate& c) {
  ByteWriter w;
  w.u8(kCertificateVersion);
  w.str8(c.ecology);
  w.raw(c.publicKey);
  w.str8(c.principal);
  w.u8(c.groups.size());
  for (const auto& g : c.groups) w.str8(g);
  w.u8(c.names.size());
  for (const auto& n : c.names) w.str8(n);
  w.u32(static_cast<std::uint32_t>(c.pinnedId));
  w.u64(static_cast<std::uint64_t>(c.issued));
  w.u64(static_cast<std::uint64_t>(c.notAfter));
  w.u64(c.serial);
  return w.take();
}

std::string encodeCertificate(const Certificate& c) { return certificateBody(c) + c.signature; }

std::optional<Certificate> decodeCertificate(std::string_view& in, std::string& error) {
  ByteReader r(in);
  Certificate c;
  if (r.u8() != kCertificateVersion) {
    error = "certificate of an unknown version";
    return std::nullopt;
  }
  c.ecology = r.str8();
  c.publicKey = std::string(r.raw(kSignPublicKeyBytes));
  c.principal = r.str8();
  for (auto n = r.u8(); n > 0 && r.ok(); --n) c.groups.push_back(r.str8());
  for (auto n = r.u8(); n > 0 && r.ok(); --n) c.names.push_back(r.str8());
  const auto id = static_cast<std::int32_t>(r.u32());
  c.issued = static_cast<std::int64_t>(r.u64());
  c.notAfter = static_cast<std::int64_t>(r.u64());
  c.serial = r.u64();
  c.signature = std::string(r.raw(kSignatureBytes));
  if (!r.ok()) {
    error = "truncated certificate";
    return std::nullopt;
  }
  if (id != 0 && !isValidPeisId(id)) {
    error = "certificate pins an invalid id";
    return std::nullopt;
  }
  if (c.principal.empty() || c.ecology.empty()) {
    error = "certificate without a principal or an ecology";
    return std::nullopt;
  }
  c.pinnedId = id;
  in.remove_prefix(r.position());
  return c;
}

void signCertificate(Certificate& c, std::string_view rootSecretKey) {
  c.signature = sign(std::string(kCertificateContext) + certificateBody(c), rootSecretKey);
}

std::optional<std::string> certificateProblem(const Certificate& c, std::string_view rootPublicKey,
                                              std::string_view ecology, std::int64_t now) {
  if (c.ecology != ecology) {
    return "its credentials are for ecology '" + c.ecology + "', not '" + std::string(ecology) +
           "'";
  }
  if (!verify(c.signature, std::string(kCertificateContext) + certificateBody(c), rootPublicKey)) {
    return "its certificate is not signed by this ecology's trust root (root " +
           fingerprint(rootPublicKey) + ")";
  }
  if (c.notAfter != 0 && now > c.notAfter) {
    return "its certificate (" + describe(c) + ") expired";
  }
  if (c.issued > now + 24 * 3600) return "its certificate is issued in the future";
  return std::nullopt;
}

bool allowsName(const Certificate& c, std::string_view name) {
  for (const auto& pattern : c.names) {
    if (!pattern.empty() && pattern.back() == '*') {
      if (name.substr(0, pattern.size() - 1) ==
          std::string_view(pattern).substr(0, pattern.size() - 1))
        return true;
    } else if (pattern == name) {
      return true;
    }
  }
  return false;
}

std::string serialText(std::uint64_t serial) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(serial));
  return text;
}

std::string describe(const Certificate& c) {
  std::string groups;
  for (const auto& g : c.groups) groups += (groups.empty() ? "" : ", ") + g;
  return "principal '" + c.principal + "'" + (groups.empty() ? "" : ", groups " + groups) +
         ", serial " + serialText(c.serial);
}

}  // namespace peis::security
