// Keys, PEIS names and full names (OWNER.KEY): validation and parsing.
// Pure functions; the rules are stated in docs/tuple-model.md.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/types.h"

namespace peis {

// Why `key` is not a valid concrete key, or nothing if it is.
std::optional<std::string> keyProblem(std::string_view key);
// Throws Error(InvalidKey) with the reason if `key` is not a valid key.
void validateKey(std::string_view key);

// Why `pattern` is not a valid key pattern (parts may be `*`, the last part
// may be `**`), or nothing if it is.
std::optional<std::string> keyPatternProblem(std::string_view pattern);

// Splits a dotted key into its parts; no validation.
std::vector<std::string_view> splitKey(std::string_view key);

// PEIS names: one key part, not all digits, at most kMaxNameBytes.
std::optional<std::string> nameProblem(std::string_view name);
void validateName(std::string_view name);

// "42" -> 42; anything that is not a decimal PEIS id -> nothing.
std::optional<PeisId> parsePeisId(std::string_view text);

// A full name OWNER.KEY where OWNER is a PEIS id or a PEIS name.
struct FullName {
  std::string owner;  // decimal id or name, as written
  std::string key;
  std::optional<PeisId> ownerId() const { return parsePeisId(owner); }
  std::string str() const { return owner + "." + key; }
  bool operator==(const FullName&) const = default;
};

// Throws Error(InvalidKey / InvalidName) on a malformed full name.
FullName parseFullName(std::string_view text);
std::string fullName(PeisId owner, std::string_view key);

}  // namespace peis
