// The kernel's log, for programs built on it too (the tinybridge, components):
// one line per event on stderr, prefixed with the time, the PEIS and the
// level, so the lines of every PEIS of a host read alike. How much is
// written is one level for the whole process: PEIS_LOG=quiet|warn|info|debug
// (default info), unless a program sets another in code (the `peis` tool
// keeps to warnings unless --verbose or PEIS_LOG asks for more).
#pragma once

#include <optional>
#include <string_view>

#include "peis/types.h"

namespace peis::log {

enum class Level { Error = 0, Warn = 1, Info = 2, Debug = 3 };

// "quiet" or "error", "warn", "info", "debug" -> the level; else nothing.
std::optional<Level> parseLevel(std::string_view text);
// The level in force: PEIS_LOG's at first use, or the one set since.
Level level();
// Sets the level for the whole process, from now on; wins over PEIS_LOG.
void setLevel(Level level);
// True when PEIS_LOG names a level (a program then leaves the level as the
// user chose it).
bool levelFromEnvironment();

// Whether lines of this level are written now.
bool enabled(Level level);
// Writes one line (if enabled) for PEIS `peis` (0 when none).
void line(Level level, PeisId peis, std::string_view message);

inline void error(PeisId peis, std::string_view m) { line(Level::Error, peis, m); }
inline void warn(PeisId peis, std::string_view m) { line(Level::Warn, peis, m); }
inline void info(PeisId peis, std::string_view m) { line(Level::Info, peis, m); }
inline void debug(PeisId peis, std::string_view m) { line(Level::Debug, peis, m); }

}  // namespace peis::log
