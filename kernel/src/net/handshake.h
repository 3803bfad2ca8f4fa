// The handshake's decision (docs/protocol.md §7): what a PEIS does with the
// Hello it receives on a link, as a pure function of that Hello and what the
// PEIS knows (its own id, incarnation and ecology, and any established link
// to the same id). The Network carries the verdict out.
#pragma once

#include <cstdint>
#include <string_view>

#include "net/wire.h"

namespace peis::net {

enum class HelloVerdict {
  Ignore,                  // a Hello on an established link (counts as malformed)
  WrongVersion,            // close
  ForeignEcology,          // close, counted
  Myself,                  // dialled itself: close
  IdMine,                  // the same id, started later: send IdTaken, close after it
  IdTheirs,                // the same id, started earlier: close and re-pick ours
  IdKept,                  // the same id, "started earlier", but ours is kept: IdTaken, close
  OtherIncarnationLinked,  // already linked to that id with another incarnation: close
  Duplicate,               // a second link to that PEIS that loses: close
  ReplacesExisting,        // a second link that wins: close the other, establish
  Establish,
};

struct HelloContext {
  PeisId self = 0;
  std::uint64_t incarnation = 0;
  std::string_view ecology;
  bool established = false;  // this link already accepted a Hello
  bool outbound = false;     // this link was dialled by us
  // The Hello of an established link to the same id, if any, and whether we
  // dialled that link.
  const wire::Hello* existing = nullptr;
  bool existingOutbound = false;
  // Whether this PEIS still gives its id up to a PEIS that claims it and
  // says it started earlier: only in its first moments in the ecology
  // (Limits::idClaimWindow), when a real earlier holder is found; later
  // such a claim is refused, as an attacker's would be (docs/security.md).
  bool mayGiveUpId = true;
};

HelloVerdict judgeHello(const HelloContext& context, const wire::Hello& hello);

}  // namespace peis::net
