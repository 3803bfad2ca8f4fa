// stderr logger and the process-wide log level; see log.h and peis/logging.h.
#include "log.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <mutex>
#include <string>

namespace peis {
namespace {

// The level PEIS_LOG names, or Info. A value that names no level is said
// once on stderr (a typo should not silently change what is logged).
LogLevel levelFromEnvironment() {
  const char* env = std::getenv("PEIS_LOG");
  if (!env || !*env) return LogLevel::Info;
  if (auto level = parseLogLevel(env)) return *level;
  std::fprintf(stderr, "peis: PEIS_LOG='%s' is not quiet|error|warn|info|debug; using info\n", env);
  return LogLevel::Info;
}

std::atomic<int>& currentLevel() {
  static std::atomic<int> level{static_cast<int>(levelFromEnvironment())};
  return level;
}

const char* name(LogLevel level) {
  switch (level) {
    case LogLevel::Error:
      return "error";
    case LogLevel::Warn:
      return "warn";
    case LogLevel::Info:
      return "info";
    case LogLevel::Debug:
      return "debug";
  }
  return "?";
}

}  // namespace

std::optional<LogLevel> parseLogLevel(std::string_view text) {
  if (text == "quiet" || text == "error") return LogLevel::Error;
  if (text == "warn") return LogLevel::Warn;
  if (text == "info") return LogLevel::Info;
  if (text == "debug") return LogLevel::Debug;
  return std::nullopt;
}

LogLevel logLevel() { return static_cast<LogLevel>(currentLevel().load()); }

void setLogLevel(LogLevel level) { currentLevel().store(static_cast<int>(level)); }

bool logLevelFromEnvironment() {
  const char* env = std::getenv("PEIS_LOG");
  return env && parseLogLevel(env).has_value();
}

namespace log {

bool enabled(Level level) { return static_cast<int>(level) <= currentLevel().load(); }

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

}  // namespace log
}  // namespace peis
