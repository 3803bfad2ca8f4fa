// Phrases and WAV durations for the talk output (see speech.h).
#include "speech.h"

#include <cstdint>
#include <stdexcept>

namespace peis::devices {

PhraseTable::PhraseTable() { phrases_["wakeup"] = "Good morning, Johanna. Time to wake up."; }

void PhraseTable::add(const std::string& rule) {
  const auto eq = rule.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == rule.size())
    throw std::invalid_argument("phrase '" + rule + "': expected KEY=TEXT");
  phrases_[rule.substr(0, eq)] = rule.substr(eq + 1);
}

std::string PhraseTable::words(const std::string& phrase) const {
  const auto it = phrases_.find(phrase);
  if (it != phrases_.end()) return it->second;
  std::string out = phrase;
  for (char& c : out)
    if (c == '-' || c == '_') c = ' ';
  return out;
}

namespace {

std::uint32_t le32(std::string_view b, std::size_t at) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(b[at])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 1])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 2])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 3])) << 24;
}

std::optional<double> fail(std::string* problem, const char* why) {
  if (problem) *problem = why;
  return std::nullopt;
}

}  // namespace

std::optional<double> wavSeconds(std::string_view b, std::string* problem) {
  if (b.size() < 12 || b.substr(0, 4) != "RIFF" || b.substr(8, 4) != "WAVE")
    return fail(problem, "not a RIFF/WAVE file");
  std::uint32_t byteRate = 0;
  for (std::size_t at = 12; at + 8 <= b.size();) {
    const std::string_view id = b.substr(at, 4);
    const std::uint32_t size = le32(b, at + 4);
    const std::size_t body = at + 8;
    if (id == "fmt ") {
      if (size < 16 || body + 16 > b.size()) return fail(problem, "short fmt chunk");
      byteRate = le32(b, body + 8);
      if (byteRate == 0) return fail(problem, "byte rate 0");
    } else if (id == "data") {
      if (byteRate == 0) return fail(problem, "data before fmt");
      // espeak-ng writing to a pipe leaves the size at 0x7fffffff: count what is there.
      const std::size_t have = b.size() - body;
      const std::size_t bytes = size > have ? have : size;
      return static_cast<double>(bytes) / byteRate;
    }
    if (size > b.size() - body) break;
    at = body + size + (size & 1);
  }
  return fail(problem, "no data chunk");
}

}  // namespace peis::devices
