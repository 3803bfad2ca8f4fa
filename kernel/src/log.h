// Minimal logging to stderr: one line per event, prefixed with the time,
// the level and the PEIS. The level is process-wide (peis/logging.h):
// PEIS_LOG=quiet|warn|info|debug, or setLogLevel() in code.
#pragma once

#include <string_view>

#include "peis/logging.h"
#include "peis/types.h"

namespace peis::log {

using Level = LogLevel;

bool enabled(Level level);
void line(Level level, PeisId peis, std::string_view message);

inline void error(PeisId peis, std::string_view m) { line(Level::Error, peis, m); }
inline void warn(PeisId peis, std::string_view m) { line(Level::Warn, peis, m); }
inline void info(PeisId peis, std::string_view m) { line(Level::Info, peis, m); }
inline void debug(PeisId peis, std::string_view m) { line(Level::Debug, peis, m); }

}  // namespace peis::log
