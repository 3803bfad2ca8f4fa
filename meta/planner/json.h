// A few helpers to write JSON by hand (the programs' --json output).
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <string_view>

#include "peis/json_string.h"

namespace peis::meta::json {

using peis::json::quote;  // the platform's one JSON escaping

inline std::string number(double value) {
  if (!std::isfinite(value)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", value);
  return buf;
}

}  // namespace peis::meta::json
