// How the `peis` tool prints: tuples as text lines or JSON objects, JSON
// strings, time stamps. Pure functions.
#pragma once

#include <string>
#include <string_view>

#include "peis/json_string.h"  // json::quote, for every command's --json
#include "peis/tuple.h"

namespace peis::cli {

// A tuple's data for a text line: as is, or "<N bytes>" when binary.
std::string printable(const Tuple& t);
// {"owner","key","data","creator","mimetype","encoding","seqno","ts_write",
// "ts_user","ts_expire"}; times in microseconds since the Unix epoch.
std::string tupleJson(const Tuple& t);
// {"owner":ID,"key":"KEY","seqno":N}: a write its owner accepted.
std::string writeResultJson(PeisId owner, std::string_view key, std::uint64_t seqno);
// "OWNER.KEY = VALUE".
std::string tupleLine(const Tuple& t);
// A time of day in local time, "HH:MM:SS.mmm".
std::string clockTime(Timestamp time);
// "12.3s", or "?" for a negative duration.
std::string seconds(double value);

}  // namespace peis::cli
