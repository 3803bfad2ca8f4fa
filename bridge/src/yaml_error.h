// The bridge's YAML errors: Error(InvalidConfig) "<origin>:<line>: <problem>",
// the line left out when yaml-cpp does not know it.
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

}  // namespace peis::bridge
