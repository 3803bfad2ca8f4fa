// The bridge's YAML errors: Error(InvalidConfig) "<origin>:<line>: <problem>",
// the line left out when yaml-cpp does not know it (the seed, the nodes'
// descriptors).
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

#include "peis/error.h"

namespace peis::bridge {

[[noreturn]] inline void failAt(const std::string& origin, const YAML::Node& node,
                                const std::string& why) {
  std::string where = origin;
  if (node.IsDefined() && node.Mark().line >= 0)
    where += ":" + std::to_string(node.Mark().line + 1);
  throw Error(ErrorCode::InvalidConfig, where + ": " + why);
}

// Parses a YAML document; a syntax error is "<origin>:<line>: broken YAML: …".
inline YAML::Node loadYaml(const std::string& text, const std::string& origin) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::InvalidConfig,
                origin + ":" + std::to_string(e.mark.line + 1) + ": broken YAML: " + e.msg);
  }
}

}  // namespace peis::bridge
