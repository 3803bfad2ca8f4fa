// The timeline; see timeline.h.
#include "timeline.h"

namespace peis::scenario {

std::string formatValue(const Tuple& tuple, std::size_t width) {
  if (tuple.encoding == Encoding::Binary)
    return "<" + std::to_string(tuple.data.size()) + " bytes " + tuple.mimetype + ">";
  std::string one;
  for (const char c : tuple.data) one += (c == '\n' || c == '\r' || c == '\t') ? ' ' : c;
  while (!one.empty() && one.back() == ' ') one.pop_back();
  if (one.size() > width) {
    // Cut at a character boundary (UTF-8 continuation bytes are 10xxxxxx).
    std::size_t cut = width;
    while (cut > 0 && (static_cast<unsigned char>(one[cut]) & 0xC0) == 0x80) --cut;
    one = one.substr(0, cut) + "…";
  }
  return one;
}

std::string formatLine(std::optional<double> seconds, const std::string& peis,
                       const std::string& words, const std::string& tuple) {
  char time[32];
  if (seconds)
    std::snprintf(time, sizeof time, "%8.1f s", *seconds);
  else
    std::snprintf(time, sizeof time, "%10s", "");
  char who[64];
  std::snprintf(who, sizeof who, "%-16s", peis.c_str());
  std::string line = std::string(time) + "  " + who + " " + words;
  if (!tuple.empty()) {
    constexpr std::size_t kTupleColumn = 92;
    line += line.size() < kTupleColumn ? std::string(kTupleColumn - line.size(), ' ') : "   ";
    line += tuple;
  }
  return line;
}

void Timeline::setSink(Sink sink) {
  std::lock_guard lock(mu_);
  sink_ = std::move(sink);
}

void Timeline::say(std::optional<double> seconds, const std::string& peis, const std::string& words,
                   const std::string& tuple) {
  std::lock_guard lock(mu_);
  const std::string line = formatLine(seconds, peis, words, tuple);
  std::fprintf(out_, "%s\n", line.c_str());
  std::fflush(out_);
  if (sink_) sink_(seconds, peis, words, tuple);
}

}  // namespace peis::scenario
