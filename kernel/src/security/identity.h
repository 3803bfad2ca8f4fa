// Identity: who a PEIS of a secured ecology is, provably — its certificate
// and its own signature binding its id, incarnation and name to the
// certificate's key (docs/protocol.md §15.3). A PEIS proves its identity
// to each neighbour in the handshake, and passes on the identities of the
// PEIS it advertises routes to, so that every PEIS can check that a route,
// a name or an id was announced by a PEIS entitled to it (IdentityBook).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "security/certificate.h"
#include "security/credentials.h"

namespace peis::security {

struct Identity {
  Certificate certificate;
  PeisId id = 0;
  std::uint64_t incarnation = 0;
  std::string name;
  std::string signature;  // by the certificate's key, over the binding
  bool operator==(const Identity&) const = default;
};

Identity makeIdentity(const Credentials& credentials, PeisId id, std::uint64_t incarnation,
                      const std::string& name);
std::string encodeIdentity(const Identity& identity);
std::optional<Identity> decodeIdentity(std::string_view& in, std::string& error);

// What a PEIS trusts: its ecology's root key and name, and the serials the
// policy revokes.
struct TrustAnchor {
  std::string ecology;
  std::string rootKey;
};
// Why `identity` is not to be believed at Unix time `now`; nullopt when it
// is: a certificate of this ecology's root, not expired, allowing the name
// and (if it pins one) the id, and the binding signed by its key.
std::optional<std::string> identityProblem(const Identity& identity, const TrustAnchor& anchor,
                                           std::int64_t now);

// The identities a PEIS has checked, by id (the latest incarnation heard).
// Bounded by its owner (the routing table's limit).
class IdentityBook {
 public:
  // Stores a checked identity; false when an older incarnation of that id
  // is offered (ignored).
  bool put(Identity identity);
  const Identity* find(PeisId id) const;
  // The entry of `id` at that incarnation and name, if checked.
  bool vouches(PeisId id, std::uint64_t incarnation, std::string_view name) const;
  void forget(PeisId id) { book_.erase(id); }
  template <typename Predicate>
  void forgetIf(Predicate forget) {
    std::erase_if(book_, [&](const auto& entry) { return forget(entry.first); });
  }
  std::size_t size() const { return book_.size(); }

 private:
  std::map<PeisId, Identity> book_;
};

}  // namespace peis::security
