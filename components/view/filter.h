// The view's tuple filter: an abstract tuple written as text, as the page's
// filter box and the --filter and --meta options take it:
//
//   OWNER.KEYPATTERN [creator=OWNER] [mimetype=TYPE]
//
// OWNER is a PEIS id, a PEIS name or `*`; KEYPATTERN uses `*` for one key
// part and a trailing `**` for the rest (docs/tuple-model.md); TYPE is a
// mimetype, or `image/*` for every mimetype that starts with `image/`.
// An empty text is `*.**` (everything). Pure: names are resolved through the
// function the caller gives.
#pragma once

#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "peis/pattern.h"

namespace peis::view {

// Resolves a PEIS name to its id; throws peis::Error when it cannot.
using OwnerResolver = std::function<PeisId(std::string_view name)>;

struct FilterError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

struct Filter {
  std::string text;  // as given (trimmed), for the page to show
  Pattern pattern;   // owner and key pattern: what is subscribed to
  std::optional<PeisId> creator;
  std::optional<std::string> mimetype;  // exact, or a prefix ending in '/' from TYPE/*

  bool matches(PeisId owner, std::string_view key, PeisId creatorId,
               std::string_view mimetypeText) const;
};

// Parses a filter; FilterError with a message for people when the text is
// not one (bad pattern, unknown option, a name that does not resolve).
// Texts longer than kMaxFilterBytes are refused.
inline constexpr std::size_t kMaxFilterBytes = 1024;
Filter parseFilter(std::string_view text, const OwnerResolver& resolve);

// Matches when any of `filters` does.
bool matchesAny(const std::vector<Filter>& filters, PeisId owner, std::string_view key,
                PeisId creator, std::string_view mimetype);

}  // namespace peis::view
