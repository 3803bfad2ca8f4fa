// How much the kernel logs on stderr, for the whole process. The default
// comes from the environment (PEIS_LOG=quiet|error|warn|info|debug, else
// info); a program may choose another level in code, which wins (the `peis`
// tool keeps to warnings unless --verbose or PEIS_LOG asks for more).
#pragma once

#include <optional>
#include <string_view>

namespace peis {

enum class LogLevel { Error = 0, Warn = 1, Info = 2, Debug = 3 };

// "quiet" or "error", "warn", "info", "debug" -> the level; else nothing.
std::optional<LogLevel> parseLogLevel(std::string_view text);
// The level in force now.
LogLevel logLevel();
// Sets the level for every Kernel of this process, from now on.
void setLogLevel(LogLevel level);
// True when PEIS_LOG names a valid level (then a program should leave the
// level as the user set it).
bool logLevelFromEnvironment();

}  // namespace peis
