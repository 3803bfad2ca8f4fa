// Text and JSON forms of tuples for the `peis` tool; see output.h.
#include "output.h"

#include <cstdio>
#include <ctime>

namespace peis::cli {

std::string jsonString(std::string_view text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
          out += buffer;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

std::string printable(const Tuple& t) {
  if (t.encoding == Encoding::Binary) return "<" + std::to_string(t.data.size()) + " bytes>";
  return t.data;
}

std::string tupleJson(const Tuple& t) {
  auto micros = [](Timestamp ts) { return std::to_string(ts.time_since_epoch().count()); };
  return "{\"owner\":" + std::to_string(t.owner) + ",\"key\":" + jsonString(t.key) +
         ",\"data\":" + jsonString(t.data) + ",\"creator\":" + std::to_string(t.creator) +
         ",\"mimetype\":" + jsonString(t.mimetype) +
         ",\"encoding\":" + (t.encoding == Encoding::Binary ? "\"binary\"" : "\"ascii\"") +
         ",\"seqno\":" + std::to_string(t.seqno) + ",\"ts_write\":" + micros(t.ts_write) +
         ",\"ts_user\":" + micros(t.ts_user) + ",\"ts_expire\":" + micros(t.ts_expire) + "}";
}

std::string writeResultJson(PeisId owner, std::string_view key, std::uint64_t seqno) {
  return "{\"owner\":" + std::to_string(owner) + ",\"key\":" + jsonString(key) +
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
