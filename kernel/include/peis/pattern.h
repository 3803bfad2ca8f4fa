// Abstract tuples: a template with a wildcard on any field, used to
// subscribe, search and register callbacks. Matching is exact and
// case-sensitive; see docs/tuple-model.md for the rules.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/tuple.h"

namespace peis {

class Pattern {
 public:
  // Everything: any owner, any key.
  Pattern();
  // `keyPattern` is dotted; a part `*` matches exactly one part and a last
  // part `**` matches one or more remaining parts. Throws Error(InvalidKey).
  explicit Pattern(std::string_view keyPattern, std::optional<PeisId> owner = std::nullopt);
  // "OWNER.KEYPATTERN" where OWNER is an id or `*`: "*.position.**".
  static Pattern parse(std::string_view text);
  static Pattern exact(PeisId owner, std::string_view key);

  Pattern& owner(PeisId id);
  Pattern& creator(PeisId id);
  Pattern& mimetype(std::string type);
  Pattern& data(std::string bytes);

  bool matches(const Tuple& tuple) const;
  bool matchesKey(std::string_view key) const;
  bool matchesOwnerAndKey(PeisId owner, std::string_view key) const;
  // The creator, mimetype and data filters alone (for a tuple whose owner
  // and key are known to match).
  bool matchesBeyondOwnerAndKey(const Tuple& tuple) const;
  // True if the pattern names one exact (owner, key).
  bool isExact() const;

  const std::optional<PeisId>& ownerFilter() const { return owner_; }
  const std::string& keyPattern() const { return key_; }
  std::string str() const;

 private:
  std::optional<PeisId> owner_;
  std::optional<PeisId> creator_;
  std::optional<std::string> mimetype_;
  std::optional<std::string> data_;
  std::string key_;
  std::vector<std::string> parts_;
  bool hasWildcard_ = false;
};

}  // namespace peis
