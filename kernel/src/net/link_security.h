// LinkSecurity: what the Network keeps about one link of a secured ecology
// (docs/protocol.md §15): the handshake under way, the peer's identity once
// its Auth checked out, the identities this PEIS has passed on over the
// link, and a SourceTag waiting for the routed frame it belongs to.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "peis/types.h"
#include "security/identity.h"
#include "security/link_handshake.h"

namespace peis::net {

struct LinkSecurity {
  std::unique_ptr<security::LinkHandshake> handshake;  // until the peer's Auth is checked
  bool keyed = false;                                  // the records are on
  std::optional<security::Identity> peer;              // who the peer proved to be
  // Identities sent on this link (id -> incarnation): before a route to a
  // PEIS is advertised here, its identity is.
  std::map<PeisId, std::uint64_t> identitiesSent;
  std::string pendingTag;  // a SourceTag for the next routed frame
};

}  // namespace peis::net
