// The pure rules of peis-replay: under which key a recorded tuple is
// published again, with which write options, and when (its recorded gap to
// the event before, divided by the speed).
#pragma once

#include <peis/tuple.h>

#include <chrono>
#include <optional>
#include <string>

namespace peis::recorder {

// Where a recorded event goes: stand-in mode (no prefix) publishes it under
// its own key as its owner; prefix mode under "P.<owner>.<key>" of the
// replaying PEIS. Nothing (with `why`) when it is not replayed: a stand-in's
// kernel.* tuples are its own kernel's, and a prefixed key must still be a
// valid key (256 bytes, 32 parts).
std::optional<std::string> replayKey(PeisId owner, const std::string& key,
                                     const std::optional<std::string>& prefix, std::string* why);

// The recorded mimetype, encoding and ts_user; an expiry becomes the same
// time to live after the new write (ts_expire - ts_write).
WriteOptions replayOptions(const Tuple& recorded);

// How long after an event received at `earlier` one received at `received`
// is due: their recorded gap divided by the speed (never negative).
std::chrono::microseconds replayOffset(Timestamp received, Timestamp earlier, double speed);

// A --prefix value: a valid key (no wildcards). Nothing, or why not.
std::optional<std::string> prefixProblem(const std::string& prefix);

}  // namespace peis::recorder
