// The kernel's log, for programs built on it too (the tinybridge, components):
// one line per event on stderr, prefixed with the time, the PEIS and the
// level, so the lines of every PEIS of a host read alike.
// PEIS_LOG=quiet|warn|info|debug picks how much (default info).
#pragma once

#include <string_view>

#include "peis/types.h"

namespace peis::log {

enum class Level { Error = 0, Warn = 1, Info = 2, Debug = 3 };

// Whether lines of this level are written (fixed at the first call).
bool enabled(Level level);
// Writes one line (if enabled) for PEIS `peis` (0 when none).
void line(Level level, PeisId peis, std::string_view message);

inline void error(PeisId peis, std::string_view m) { line(Level::Error, peis, m); }
inline void warn(PeisId peis, std::string_view m) { line(Level::Warn, peis, m); }
inline void info(PeisId peis, std::string_view m) { line(Level::Info, peis, m); }
inline void debug(PeisId peis, std::string_view m) { line(Level::Debug, peis, m); }

}  // namespace peis::log
