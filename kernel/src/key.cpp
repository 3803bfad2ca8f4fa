// Key, name and full-name rules (docs/tuple-model.md, "Keys").
#include "peis/key.h"

#include <charconv>

#include "peis/error.h"

namespace peis {
namespace {

bool isKeyChar(char c) {
  const auto u = static_cast<unsigned char>(c);
  return u >= 0x21 && u <= 0x7e && c != '.' && c != '*' && c != '=';
}

std::optional<std::string> partProblem(std::string_view part, std::size_t index) {
  if (part.empty()) {
    return "part " + std::to_string(index + 1) + " is empty";
  }
  for (char c : part) {
    if (!isKeyChar(c)) {
      const auto u = static_cast<unsigned>(static_cast<unsigned char>(c));
      return "part " + std::to_string(index + 1) + " has the character " +
             (u >= 0x21 && u <= 0x7e
                  ? "'" + std::string(1, c) + "'"
                  : std::string("0x") + "0123456789abcdef"[u >> 4] + "0123456789abcdef"[u & 0xf]) +
             ", which keys may not contain";
    }
  }
  return std::nullopt;
}

std::optional<std::string> commonProblem(std::string_view key,
                                         const std::vector<std::string_view>& parts) {
  if (key.empty()) return std::string("the key is empty");
  if (key.size() > kMaxKeyBytes) {
    return "the key is " + std::to_string(key.size()) + " bytes long; at most " +
           std::to_string(kMaxKeyBytes) + " are allowed";
  }
  if (parts.size() > kMaxKeyParts) {
    return "the key has " + std::to_string(parts.size()) + " parts; at most " +
           std::to_string(kMaxKeyParts) + " are allowed";
  }
  return std::nullopt;
}

}  // namespace

std::vector<std::string_view> splitKey(std::string_view key) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (true) {
    const auto dot = key.find('.', start);
    if (dot == std::string_view::npos) {
      parts.push_back(key.substr(start));
      return parts;
    }
    parts.push_back(key.substr(start, dot - start));
    start = dot + 1;
  }
}

std::optional<std::string> keyProblem(std::string_view key) {
  // The common case, a valid key, allocates nothing.
  std::size_t parts = 1, partStart = 0;
  bool valid = !key.empty() && key.size() <= kMaxKeyBytes;
  for (std::size_t i = 0; valid && i < key.size(); ++i) {
    if (key[i] == '.') {
      valid = i > partStart;
      partStart = i + 1;
      ++parts;
    } else {
      valid = isKeyChar(key[i]);
    }
  }
  if (valid && partStart < key.size() && parts <= kMaxKeyParts) return std::nullopt;
  const auto split = splitKey(key);
  if (auto problem = commonProblem(key, split)) return problem;
  for (std::size_t i = 0; i < split.size(); ++i) {
    if (auto problem = partProblem(split[i], i)) return problem;
  }
  return std::nullopt;
}

void validateKey(std::string_view key) {
  if (auto problem = keyProblem(key)) {
    throw Error(ErrorCode::InvalidKey, "invalid key '" + std::string(key.substr(0, 64)) +
                                           (key.size() > 64 ? "...'" : "'") + ": " + *problem);
  }
}

std::optional<std::string> keyPatternProblem(std::string_view pattern) {
  const auto parts = splitKey(pattern);
  if (auto problem = commonProblem(pattern, parts)) return problem;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (parts[i] == "*") continue;
    if (parts[i] == "**") {
      if (i + 1 == parts.size()) continue;
      return std::string("'**' may only be the last part");
    }
    if (auto problem = partProblem(parts[i], i)) return problem;
  }
  return std::nullopt;
}

std::optional<PeisId> parsePeisId(std::string_view text) {
  if (text.empty() || text.size() > 10) return std::nullopt;
  std::int64_t value = 0;
  const auto* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || text[0] == '+' || text[0] == '-') {
    return std::nullopt;
  }
  if (!isValidPeisId(value)) return std::nullopt;
  return static_cast<PeisId>(value);
}

std::optional<std::string> nameProblem(std::string_view name) {
  if (name.empty()) return std::string("the name is empty");
  if (name.size() > kMaxNameBytes) {
    return "the name is " + std::to_string(name.size()) + " bytes long; at most " +
           std::to_string(kMaxNameBytes) + " are allowed";
  }
  if (name.find('.') != std::string_view::npos) {
    return std::string("a name may not contain '.'");
  }
  if (auto problem = partProblem(name, 0)) {
    return "the name " + problem->substr(problem->find("has"));
  }
  bool allDigits = true;
  for (char c : name) allDigits = allDigits && c >= '0' && c <= '9';
  if (allDigits) return std::string("a name may not be all digits (ids are)");
  return std::nullopt;
}

void validateName(std::string_view name) {
  if (auto problem = nameProblem(name)) {
    throw Error(ErrorCode::InvalidName,
                "invalid PEIS name '" + std::string(name.substr(0, 64)) + "': " + *problem);
  }
}

FullName parseFullName(std::string_view text) {
  const auto dot = text.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == text.size()) {
    throw Error(ErrorCode::InvalidKey,
                "invalid full name '" + std::string(text.substr(0, 64)) +
                    "': expected OWNER.KEY, e.g. 7.position.x or Astrid.position");
  }
  FullName name{std::string(text.substr(0, dot)), std::string(text.substr(dot + 1))};
  if (!name.ownerId()) {
    bool allDigits = true;
    for (char c : name.owner) allDigits = allDigits && c >= '0' && c <= '9';
    if (allDigits) {
      throw Error(ErrorCode::InvalidName, "invalid full name '" + std::string(text.substr(0, 64)) +
                                              "': owner id " + name.owner + " is out of range 1.." +
                                              std::to_string(kMaxPeisId));
    }
    validateName(name.owner);
  }
  validateKey(name.key);
  return name;
}

std::string fullName(PeisId owner, std::string_view key) {
  return std::to_string(owner) + "." + std::string(key);
}

}  // namespace peis
