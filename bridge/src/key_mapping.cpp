// Tiny keys <-> full keys (see key_mapping.h).
#include "key_mapping.h"

#include <vector>

#include "peis/key.h"

namespace peis::bridge {
namespace {

std::string partOf(const KeyRegistry& registry, std::uint16_t index) {
  if (auto name = registry.nameOf(index)) return *name;
  return "#" + std::to_string(index);
}

// "#N" -> N when N is 1..65535 in plain decimal.
std::optional<KeyIndex> rawIndex(std::string_view part) {
  if (part.size() < 2 || part.size() > 6 || part[0] != '#' || part[1] == '0') return std::nullopt;
  long value = 0;
  for (char c : part.substr(1)) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + (c - '0');
  }
  if (value < 1 || value > 65535) return std::nullopt;
  return static_cast<KeyIndex>(value);
}

}  // namespace

std::string fullKeyOf(const KeyRegistry& registry, const tiny_key& key) {
  std::string out;
  for (std::uint8_t i = 0; i < key.len && i < TINY_MAX_SUBKEYS; ++i) {
    if (i > 0) out += '.';
    out += partOf(registry, key.sub[i]);
  }
  return out;
}

std::optional<tiny_key> tinyKeyOf(KeyRegistry& registry, std::string_view fullKey, bool intern,
                                  std::string* why) {
  auto fail = [&](std::string reason) -> std::optional<tiny_key> {
    if (why != nullptr) *why = std::move(reason);
    return std::nullopt;
  };
  const auto parts = splitKey(fullKey);
  if (parts.empty() || parts.size() > TINY_MAX_SUBKEYS)
    return fail("a tiny key has 1.." + std::to_string(TINY_MAX_SUBKEYS) + " parts, '" +
                std::string(fullKey) + "' has " + std::to_string(parts.size()));
  tiny_key key{};
  key.len = static_cast<std::uint8_t>(parts.size());
  // Every part is checked before any is interned: a key that fails leaves
  // no new index behind (an index, once given, is given for good).
  std::vector<std::size_t> unknown;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (!parts[i].empty() && parts[i][0] == '#') {
      auto raw = rawIndex(parts[i]);
      if (!raw) return fail("'" + std::string(parts[i]) + "' is not a raw index #1..#65535");
      key.sub[i] = *raw;
    } else if (auto known = registry.find(parts[i])) {
      key.sub[i] = *known;
    } else if (!intern) {
      return fail("'" + std::string(parts[i]) + "' has no tiny key index");
    } else if (auto problem = registryNameProblem(parts[i])) {
      return fail("'" + std::string(parts[i]) + "' cannot be a tiny key: " + *problem);
    } else {
      unknown.push_back(i);
    }
  }
  for (const auto i : unknown) key.sub[i] = registry.intern(parts[i]);
  return key;
}

std::string fullKeyPatternOf(const KeyRegistry& registry, const tiny_key& key, bool prefix) {
  std::string out = fullKeyOf(registry, key);
  if (prefix) out += out.empty() ? "**" : ".**";
  return out;
}

}  // namespace peis::bridge
