// Text and JSON forms of tuples for the `peis` tool; see output.h.
#include "output.h"

#include <cstdio>
#include <ctime>

namespace peis::cli {

std::string printable(const Tuple& t) {
  if (t.encoding == Encoding::Binary) return "<" + std::to_string(t.data.size()) + " bytes>";
  return t.data;
}

std::string tupleJson(const Tuple& t) {
  auto micros = [](Timestamp ts) { return std::to_string(ts.time_since_epoch().count()); };
  return "{\"owner\":" + std::to_string(t.owner) + ",\"key\":" + json::quote(t.key) +
         ",\"data\":" + json::quote(t.data) + ",\"creator\":" + std::to_string(t.creator) +
         ",\"mimetype\":" + json::quote(t.mimetype) +
         ",\"encoding\":" + (t.encoding == Encoding::Binary ? "\"binary\"" : "\"ascii\"") +
         ",\"seqno\":" + std::to_string(t.seqno) + ",\"ts_write\":" + micros(t.ts_write) +
         ",\"ts_user\":" + micros(t.ts_user) + ",\"ts_expire\":" + micros(t.ts_expire) + "}";
}

std::string writeResultJson(PeisId owner, std::string_view key, std::uint64_t seqno) {
  return "{\"owner\":" + std::to_string(owner) + ",\"key\":" + json::quote(key) +
         ",\"seqno\":" + std::to_string(seqno) + "}";
}

std::string tupleLine(const Tuple& t) { return t.fullName() + " = " + printable(t); }

std::string clockTime(Timestamp time) {
  const auto micros = time.time_since_epoch().count();
  const std::time_t secondsPart = static_cast<std::time_t>(micros / 1000000);
  std::tm tm{};
  localtime_r(&secondsPart, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%H:%M:%S", &tm);
  char full[48];
  std::snprintf(full, sizeof full, "%s.%03d", text, static_cast<int>((micros / 1000) % 1000));
  return full;
}

std::string seconds(double value) {
  if (value < 0) return "?";
  char text[32];
  std::snprintf(text, sizeof text, "%.1fs", value);
  return text;
}

}  // namespace peis::cli
