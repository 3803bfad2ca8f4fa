// Small helpers for reading the meta-level's YAML files (model, goals, task
// domains and problems) with errors that name "<origin>:<line>: <problem>".
#pragma once

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <string_view>

#include "peis/descriptor.h"
#include "peis/error.h"

namespace peis::meta::yaml {

[[noreturn]] inline void fail(std::string_view origin, const YAML::Node& node,
                              const std::string& why) {
  std::string where(origin);
  if (node.IsDefined() && node.Mark().line >= 0)
    where += ":" + std::to_string(node.Mark().line + 1);
  throw Error(ErrorCode::InvalidConfig, where + ": " + why);
}

inline void onlyKeys(std::string_view origin, const YAML::Node& map,
                     const std::set<std::string>& allowed, const std::string& what) {
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  if (!map.IsMap()) fail(origin, map, what + " must be a mapping (keys: " + list + ")");
  for (const auto& item : map) {
    const auto key = item.first.as<std::string>();
    if (!allowed.count(key)) {
      fail(origin, item.first, "unknown key '" + key + "' in " + what + " (known: " + list + ")");
    }
  }
}

// The value of a required key; when it is missing, the error names the line
// of the mapping that lacks it.
inline YAML::Node field(std::string_view origin, const YAML::Node& map, const char* key,
                        const std::string& what) {
  const YAML::Node node = map[key];
  if (!node) fail(origin, map, what + " is missing");
  return node;
}

inline std::string scalar(std::string_view origin, const YAML::Node& node,
                          const std::string& what) {
  if (!node) fail(origin, node, what + " is missing");
  if (!node.IsScalar()) fail(origin, node, what + " must be a plain value");
  return node.as<std::string>();
}

inline double number(std::string_view origin, const YAML::Node& node, const std::string& what) {
  double value = 0;
  try {
    value = node.as<double>();
  } catch (const YAML::Exception&) {
    fail(origin, node, what + " must be a number");
  }
  if (!(value >= 0) || value > 1e12) fail(origin, node, what + " must be finite and >= 0");
  return value;
}

inline bool boolean(std::string_view origin, const YAML::Node& node, const std::string& what) {
  try {
    return node.as<bool>();
  } catch (const YAML::Exception&) {
    fail(origin, node, what + " must be true or false");
  }
}

inline YAML::Node sequence(std::string_view origin, const YAML::Node& node,
                           const std::string& what) {
  if (!node.IsSequence()) fail(origin, node, what + " must be a list");
  return node;
}

inline Term term(std::string_view origin, const YAML::Node& node, const std::string& what) {
  const auto text = scalar(origin, node, what);
  std::string problem;
  auto t = Term::parse(text, &problem);
  if (!t) fail(origin, node, what + " '" + text + "' is not a term: " + problem);
  return *t;
}

// Loads a document; YAML syntax errors become "<origin>:<line>: not valid YAML: …".
inline YAML::Node load(std::string_view text, std::string_view origin) {
  try {
    return YAML::Load(std::string(text));
  } catch (const YAML::Exception& e) {
    throw Error(
        ErrorCode::InvalidConfig,
        std::string(origin) + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
}

inline std::string readFile(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorCode::InvalidConfig, path + ": cannot open the " + what);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Runs `parse`, turning yaml-cpp's own exceptions into InvalidConfig with a line.
template <typename F>
auto guarded(std::string_view origin, F&& parse) {
  try {
    return parse();
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::InvalidConfig,
                std::string(origin) + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

}  // namespace peis::meta::yaml
