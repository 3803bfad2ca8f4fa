// The rules of peis-replay (see replay_plan.h).
#include "recorder/replay_plan.h"

#include <peis/key.h>

#include <cmath>

namespace peis::recorder {

std::optional<std::string> replayKey(PeisId owner, const std::string& key,
                                     const std::optional<std::string>& prefix, std::string* why) {
  if (!prefix) {
    if (key.rfind("kernel.", 0) == 0) {
      if (why) *why = "a stand-in's kernel.* tuples are its own kernel's";
      return std::nullopt;
    }
    return key;
  }
  std::string full = *prefix + "." + std::to_string(owner) + "." + key;
  if (const auto problem = keyProblem(full)) {
    if (why) *why = *problem;
    return std::nullopt;
  }
  return full;
}

WriteOptions replayOptions(const Tuple& recorded) {
  WriteOptions options;
  options.mimetype = recorded.mimetype;
  options.encoding = recorded.encoding;
  options.ts_user = recorded.ts_user;
  if (recorded.ts_expire != kNoTime && recorded.ts_expire > recorded.ts_write)
    options.ttl = recorded.ts_expire - recorded.ts_write;
  else if (recorded.ts_expire != kNoTime)
    options.ttl = std::chrono::microseconds(1);  // it had expired as it was written
  return options;
}

std::chrono::microseconds replayOffset(Timestamp received, Timestamp earlier, double speed) {
  const double us = static_cast<double>((received - earlier).count()) / speed;
  return std::chrono::microseconds(us <= 0 ? 0 : static_cast<long long>(std::llround(us)));
}

std::optional<std::string> prefixProblem(const std::string& prefix) {
  if (prefix.find('*') != std::string::npos) return "a prefix has no wildcards";
  return keyProblem(prefix);
}

}  // namespace peis::recorder
