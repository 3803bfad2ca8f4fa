// YamlNode: a parsed YAML document as plain values (the security module
// parses with yaml-cpp and hands this over; the kernel's readers of
// credentials, trust roots and policies walk it). Only what those files
// use: scalars, sequences and mappings with scalar keys, and each node's
// line for error messages.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace peis::security {

struct YamlNode {
  enum class Kind { Undefined, Null, Scalar, Sequence, Map };
  Kind kind = Kind::Undefined;
  int line = -1;       // 0-based; -1: unknown
  std::string scalar;  // a Scalar's text
  // A Sequence's items; a Map's values, keyed by keys[i] (in file order).
  std::vector<YamlNode> items;
  std::vector<YamlNode> keys;

  bool isDefined() const { return kind != Kind::Undefined; }
  bool isNull() const { return kind == Kind::Null; }
  bool isScalar() const { return kind == Kind::Scalar; }
  bool isSequence() const { return kind == Kind::Sequence; }
  bool isMap() const { return kind == Kind::Map; }
  explicit operator bool() const { return isDefined(); }

  // A Map's value of `key`; an Undefined node (on the map's line) when it
  // has none or this is not a Map.
  YamlNode operator[](std::string_view key) const {
    if (isMap()) {
      for (std::size_t i = 0; i < keys.size(); ++i) {
        if (keys[i].isScalar() && keys[i].scalar == key) return items[i];
      }
    }
    YamlNode none;
    none.line = line;
    return none;
  }
};

}  // namespace peis::security
