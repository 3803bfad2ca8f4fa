// stderr logger; see peis/log.h.
#include "log.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <mutex>

namespace peis::log {
namespace {

Level configuredLevel() {
  const char* env = std::getenv("PEIS_LOG");
  if (!env) return Level::Info;
  if (std::strcmp(env, "quiet") == 0) return Level::Error;
  if (std::strcmp(env, "warn") == 0) return Level::Warn;
  if (std::strcmp(env, "debug") == 0) return Level::Debug;
  return Level::Info;
}

const char* name(Level level) {
  switch (level) {
    case Level::Error:
      return "error";
    case Level::Warn:
      return "warn";
    case Level::Info:
      return "info";
    case Level::Debug:
      return "debug";
  }
  return "?";
}

}  // namespace

bool enabled(Level level) {
  static const Level configured = configuredLevel();
  return level <= configured;
}

void line(Level level, PeisId peis, std::string_view message) {
  if (!enabled(level)) return;
  static std::mutex mu;
  const auto now = systemNow().time_since_epoch().count();
  const std::time_t seconds = static_cast<std::time_t>(now / 1000000);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%H:%M:%S", &tm);
  std::lock_guard lock(mu);
  std::fprintf(stderr, "%s.%03d peis[%d] %s: %.*s\n", stamp, static_cast<int>((now / 1000) % 1000),
               peis, name(level), static_cast<int>(message.size()), message.data());
}

}  // namespace peis::log
