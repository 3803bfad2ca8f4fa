// stderr logger and the process-wide log level; see peis/log.h.
#include "log.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <mutex>

namespace peis::log {
namespace {

// The level PEIS_LOG names, or Info. A value that names no level is said
// once on stderr (a typo should not silently change what is logged).
Level levelFromVariable() {
  const char* env = std::getenv("PEIS_LOG");
  if (!env || !*env) return Level::Info;
  if (auto level = parseLevel(env)) return *level;
  std::fprintf(stderr, "peis: PEIS_LOG='%s' is not quiet|error|warn|info|debug; using info\n", env);
  return Level::Info;
}

std::atomic<int>& current() {
  static std::atomic<int> level{static_cast<int>(levelFromVariable())};
  return level;
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

std::optional<Level> parseLevel(std::string_view text) {
  if (text == "quiet" || text == "error") return Level::Error;
  if (text == "warn") return Level::Warn;
  if (text == "info") return Level::Info;
  if (text == "debug") return Level::Debug;
  return std::nullopt;
}

Level level() { return static_cast<Level>(current().load()); }

void setLevel(Level level) { current().store(static_cast<int>(level)); }

bool levelFromEnvironment() {
  const char* env = std::getenv("PEIS_LOG");
  return env && parseLevel(env).has_value();
}

bool enabled(Level level) { return static_cast<int>(level) <= current().load(); }

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
