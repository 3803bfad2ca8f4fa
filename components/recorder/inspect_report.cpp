// peis-inspect's report (see inspect_report.h).
#include "recorder/inspect_report.h"

#include <cstdio>
#include <sstream>

#include "peis/json_string.h"

namespace peis::recorder {
namespace {

double seconds(Timestamp from, Timestamp to) {
  return static_cast<double>((to - from).count()) / 1e6;
}

std::string value(const RecordingSummary& s, const std::string& name, const std::string& none) {
  const auto it = s.values.find(name);
  return it == s.values.end() || it->second.empty() ? none : it->second;
}

Timestamp spanStart(const RecordingSummary& s) {
  if (s.started && (s.events() == 0 || *s.started <= s.first)) return *s.started;
  return s.first;
}

std::string fixed(double x, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, x);
  return text;
}

std::string bytesText(std::int64_t bytes) {
  if (bytes < 1024) return std::to_string(bytes) + " B";
  if (bytes < 1024 * 1024) return fixed(static_cast<double>(bytes) / 1024, 1) + " KiB";
  return fixed(static_cast<double>(bytes) / (1024 * 1024), 1) + " MiB";
}

double rate(std::int64_t count, double span) {
  return span > 0 ? static_cast<double>(count) / span : 0;
}

std::string ownerText(const RecordingSummary& s, PeisId id) {
  const auto it = s.owners.find(id);
  return std::to_string(id) +
         (it != s.owners.end() && !it->second.empty() ? " (" + it->second + ")" : "");
}

}  // namespace

double spanSeconds(const RecordingSummary& s) {
  const Timestamp start = spanStart(s);
  const Timestamp end = s.ended && *s.ended >= s.last ? *s.ended : s.last;
  return s.events() == 0 && !s.ended ? 0 : std::max(0.0, seconds(start, end));
}

std::string inspectText(const RecordingSummary& s, const std::string& path) {
  std::ostringstream out;
  const double span = spanSeconds(s);
  const Timestamp start = spanStart(s);
  out << path << "\n";
  out << "  format      " << value(s, "format", "?") << " " << value(s, "version", "?")
      << ", commit interval " << value(s, "commit_interval_ms", "?") << " ms\n";
  out << "  recorded    by PEIS " << value(s, "recorder", "?") << " on " << value(s, "host", "?")
      << ", ecology '" << value(s, "ecology", "?") << "', patterns " << value(s, "patterns", "?")
      << "\n";
  out << "  span        ";
  if (s.events() == 0 && !s.started)
    out << "-\n";
  else
    out << formatTime(start) << " .. "
        << formatTime(start + std::chrono::microseconds(static_cast<long long>(span * 1e6)))
        << " UTC (" << fixed(span, 3) << " s)\n";
  out << "  ended       "
      << (s.ended ? "cleanly"
                  : "no: the recorder did not stop cleanly (killed?); the span ends at the "
                    "last event")
      << "\n";
  out << "  events      " << s.events() << ": " << s.changes << " changes, " << s.deletions
      << " deletions; " << fixed(rate(s.events(), span), 1) << " /s; " << bytesText(s.bytes)
      << " of data\n";
  out << "  owners      ";
  if (s.owners.empty()) out << "-";
  bool firstOwner = true;
  for (const auto& [id, name] : s.owners) {
    out << (firstOwner ? "" : ", ") << ownerText(s, id);
    firstOwner = false;
  }
  out << "\n  dropped     " << value(s, "dropped", "0") << "\n";
  if (s.tuples.empty()) return out.str();
  std::size_t width = 5;
  for (const auto& t : s.tuples)
    width = std::max(width, std::to_string(t.owner).size() + 1 + t.key.size());
  char line[512];
  std::snprintf(line, sizeof line, "\n%-*s %9s %9s %10s %12s %10s %10s\n", static_cast<int>(width),
                "TUPLE", "CHANGES", "DELETIONS", "RATE/S", "BYTES", "FIRST S", "LAST S");
  out << line;
  for (const auto& t : s.tuples) {
    const std::string name = std::to_string(t.owner) + "." + t.key;
    std::snprintf(line, sizeof line, "%-*s %9lld %9lld %10.2f %12lld %10.3f %10.3f\n",
                  static_cast<int>(width), name.c_str(), static_cast<long long>(t.changes),
                  static_cast<long long>(t.deletions), rate(t.changes + t.deletions, span),
                  static_cast<long long>(t.bytes), seconds(start, t.first), seconds(start, t.last));
    out << line;
  }
  return out.str();
}

std::string inspectJson(const RecordingSummary& s, const std::string& path) {
  const double span = spanSeconds(s);
  const auto micros = [](Timestamp t) { return std::to_string(t.time_since_epoch().count()); };
  std::ostringstream out;
  out << "{\"file\":" << json::quote(path) << ",\"format\":" << json::quote(value(s, "format", ""))
      << ",\"version\":" << json::quote(value(s, "version", ""))
      << ",\"ecology\":" << json::quote(value(s, "ecology", ""))
      << ",\"host\":" << json::quote(value(s, "host", ""))
      << ",\"recorder\":" << json::quote(value(s, "recorder", ""))
      << ",\"patterns\":" << json::quote(value(s, "patterns", ""))
      << ",\"started_us\":" << (s.started ? micros(*s.started) : "null")
      << ",\"ended_us\":" << (s.ended ? micros(*s.ended) : "null")
      << ",\"clean\":" << (s.ended ? "true" : "false") << ",\"span_s\":" << fixed(span, 6)
      << ",\"events\":" << s.events() << ",\"changes\":" << s.changes
      << ",\"deletions\":" << s.deletions << ",\"bytes\":" << s.bytes
      << ",\"rate_per_s\":" << fixed(rate(s.events(), span), 3)
      << ",\"dropped\":" << value(s, "dropped", "0") << ",\"owners\":[";
  bool first = true;
  for (const auto& [id, name] : s.owners) {
    out << (first ? "" : ",") << "{\"id\":" << id << ",\"name\":" << json::quote(name) << "}";
    first = false;
  }
  out << "],\"tuples\":[";
  first = true;
  for (const auto& t : s.tuples) {
    out << (first ? "" : ",") << "{\"owner\":" << t.owner << ",\"key\":" << json::quote(t.key)
        << ",\"changes\":" << t.changes << ",\"deletions\":" << t.deletions
        << ",\"bytes\":" << t.bytes
        << ",\"rate_per_s\":" << fixed(rate(t.changes + t.deletions, span), 3)
        << ",\"first_us\":" << micros(t.first) << ",\"last_us\":" << micros(t.last) << "}";
    first = false;
  }
  out << "]}";
  return out.str();
}

}  // namespace peis::recorder
