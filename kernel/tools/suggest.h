// "Did you mean": the existing names closest to a misspelt one (a key, a
// PEIS name, a command), by edit distance. Pure functions.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace peis::cli {

// Edits (insert, delete, replace, swap of neighbours) between a and b.
std::size_t editDistance(std::string_view a, std::string_view b);

// The candidates close enough to `wanted` to be what was meant, closest
// first (ties by name), at most `limit`. Case does not count as a difference
// of its own; nothing when no candidate is close.
std::vector<std::string> closestNames(std::string_view wanted,
                                      const std::vector<std::string>& candidates,
                                      std::size_t limit = 3);

// "; did you mean 'a'?", "; did you mean 'a' or 'b'?", or "" for none.
std::string didYouMean(const std::vector<std::string>& names);

}  // namespace peis::cli
