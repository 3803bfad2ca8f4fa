// Tiny keys <-> full keys through the key registry: the sub-keys [42] are
// the full key "LightValue", [7, 42] are "<name of 7>.LightValue"; an index
// without a name is the part "#N" (and a full key part "#N" is index N).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "key_registry.h"
#include "tiny_tuple.h"

namespace peis::bridge {

// The full key of a tiny key (len 1..7). Never fails.
std::string fullKeyOf(const KeyRegistry& registry, const tiny_key& key);

// The tiny key of a full key. With `intern`, parts without an index get one
// (persisted); without, such a key has no tiny key. On failure returns
// nullopt and says why in *why (more than 7 parts, a bad "#N", no index,
// a part that cannot be a name), having interned nothing. Error(Refused)
// if interning finds the registry full.
std::optional<tiny_key> tinyKeyOf(KeyRegistry& registry, std::string_view fullKey, bool intern,
                                  std::string* why);

// The full key pattern of a tiny subscription: the key's parts, then ".**"
// for a prefix ("**" alone for the empty prefix).
std::string fullKeyPatternOf(const KeyRegistry& registry, const tiny_key& key, bool prefix);

}  // namespace peis::bridge
