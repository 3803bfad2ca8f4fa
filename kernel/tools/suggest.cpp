// Closest names by edit distance; see suggest.h.
#include "suggest.h"

#include <algorithm>
#include <cctype>
#include <set>
#include <utility>

namespace peis::cli {
namespace {

std::string lower(std::string_view text) {
  std::string out(text);
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// How far a candidate may be and still be offered: one edit for short
// words, a quarter of the length for longer ones, never more than three.
std::size_t tolerance(std::string_view wanted) {
  return std::min<std::size_t>(3, 1 + wanted.size() / 4);
}

}  // namespace

// Optimal string alignment distance: Levenshtein plus transpositions of
// neighbours ("lmap" is one edit from "lamp").
std::size_t editDistance(std::string_view a, std::string_view b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[n][m];
}

std::vector<std::string> closestNames(std::string_view wanted,
                                      const std::vector<std::string>& candidates,
                                      std::size_t limit) {
  const auto wantedLower = lower(wanted);
  std::set<std::pair<std::size_t, std::string>> ranked;
  for (const auto& candidate : candidates) {
    if (candidate == wanted) continue;
    const auto distance = editDistance(wantedLower, lower(candidate));
    if (distance <= tolerance(wanted)) ranked.emplace(distance, candidate);
  }
  std::vector<std::string> names;
  for (const auto& [distance, name] : ranked) {
    if (names.size() >= limit) break;
    if (names.empty() || names.back() != name) names.push_back(name);
  }
  return names;
}

std::string didYouMean(const std::vector<std::string>& names) {
  if (names.empty()) return "";
  std::string text = "; did you mean ";
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) text += i + 1 == names.size() ? " or " : ", ";
    text += "'" + names[i] + "'";
  }
  return text + "?";
}

}  // namespace peis::cli
