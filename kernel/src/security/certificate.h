// Certificate: the trust root's signed statement about one credential — who
// holds it (the principal), its groups, the PEIS names its holders may use,
// an id it pins, its public key and its lifetime (docs/security.md,
// docs/protocol.md §15.2 has the bytes). Pure functions: encoding,
// signing, and the checks a PEIS makes before it believes one.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/types.h"

namespace peis::security {

struct Certificate {
  std::string ecology;
  std::string publicKey;  // the holder's Ed25519 key, 32 bytes
  std::string principal;  // who holds it, for policies
  std::vector<std::string> groups;
  // The PEIS names its holders may use: exact, or a prefix ending in '*'
  // ("camera-*"; "*" allows any name).
  std::vector<std::string> names;
  PeisId pinnedId = 0;        // its holder always has this id (0: none pinned)
  std::int64_t issued = 0;    // Unix seconds
  std::int64_t notAfter = 0;  // Unix seconds; 0: never expires
  std::uint64_t serial = 0;   // random; what a revocation names
  std::string signature;      // the root's, over body()
  bool operator==(const Certificate&) const = default;
};

// The signed bytes (everything but the signature).
std::string certificateBody(const Certificate& certificate);
// Body, then the 64-byte signature.
std::string encodeCertificate(const Certificate& certificate);
// Reads one certificate from the front of `in`; advances `in` past it.
// nullopt with the reason in `error` for anything malformed.
std::optional<Certificate> decodeCertificate(std::string_view& in, std::string& error);

void signCertificate(Certificate& certificate, std::string_view rootSecretKey);
// Why this certificate is not to be believed in ecology `ecology` under
// `rootPublicKey` at Unix time `now`; nullopt when it is.
std::optional<std::string> certificateProblem(const Certificate& certificate,
                                              std::string_view rootPublicKey,
                                              std::string_view ecology, std::int64_t now);
// Whether a holder may use PEIS name `name`.
bool allowsName(const Certificate& certificate, std::string_view name);
// "principal 'lamp' (groups devices; serial 1a2b…)"
std::string describe(const Certificate& certificate);
std::string serialText(std::uint64_t serial);

}  // namespace peis::security
