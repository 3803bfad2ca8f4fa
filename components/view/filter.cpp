// Parsing and matching the view's tuple filters (filter.h).
#include "view/filter.h"

#include <sstream>

#include "peis/error.h"
#include "peis/key.h"

namespace peis::view {
namespace {

std::string trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r\n");
  return std::string(text.substr(first, last - first + 1));
}

PeisId ownerId(const std::string& word, const OwnerResolver& resolve) {
  if (auto id = parsePeisId(word)) return *id;
  if (auto problem = nameProblem(word)) {
    throw FilterError("'" + word + "' is neither a PEIS id nor a PEIS name: " + *problem);
  }
  try {
    return resolve(word);
  } catch (const Error& e) {
    throw FilterError(e.what());
  }
}

}  // namespace

bool Filter::matches(PeisId owner, std::string_view key, PeisId creatorId,
                     std::string_view mimetypeText) const {
  if (!pattern.matchesOwnerAndKey(owner, key)) return false;
  if (creator && *creator != creatorId) return false;
  if (mimetype) {
    if (!mimetype->empty() && mimetype->back() == '/') {
      if (mimetypeText.substr(0, mimetype->size()) != *mimetype) return false;
    } else if (mimetypeText != *mimetype) {
      return false;
    }
  }
  return true;
}

Filter parseFilter(std::string_view text, const OwnerResolver& resolve) {
  if (text.size() > kMaxFilterBytes) {
    throw FilterError("a filter of " + std::to_string(text.size()) + " bytes is over the " +
                      std::to_string(kMaxFilterBytes) + "-byte limit");
  }
  Filter filter;
  filter.text = trim(text);
  if (filter.text.empty()) filter.text = "*.**";
  std::istringstream words(filter.text);
  std::string patternText;
  words >> patternText;
  const auto dot = patternText.find('.');
  if (dot == std::string::npos || dot == 0) {
    throw FilterError("'" + patternText +
                      "' is not a pattern: write OWNER.KEYPATTERN, e.g. *.status or lamp.light.*");
  }
  const std::string owner = patternText.substr(0, dot);
  const std::string keyPattern = patternText.substr(dot + 1);
  if (auto problem = keyPatternProblem(keyPattern)) {
    throw FilterError("bad key pattern '" + keyPattern + "': " + *problem);
  }
  std::optional<PeisId> ownerFilter;
  if (owner != "*") ownerFilter = ownerId(owner, resolve);
  filter.pattern = Pattern(keyPattern, ownerFilter);
  for (std::string word; words >> word;) {
    const auto eq = word.find('=');
    const std::string name = word.substr(0, eq);
    const std::string value = eq == std::string::npos ? "" : word.substr(eq + 1);
    if (eq == std::string::npos || value.empty()) {
      throw FilterError("'" + word + "': write creator=OWNER or mimetype=TYPE after the pattern");
    }
    if (name == "creator") {
      filter.creator = ownerId(value, resolve);
    } else if (name == "mimetype") {
      filter.mimetype = value.size() >= 2 && value.substr(value.size() - 2) == "/*"
                            ? value.substr(0, value.size() - 1)
                            : value;
    } else {
      throw FilterError("unknown filter option '" + name + "' (known: creator, mimetype)");
    }
  }
  return filter;
}

bool matchesAny(const std::vector<Filter>& filters, PeisId owner, std::string_view key,
                PeisId creator, std::string_view mimetype) {
  for (const auto& filter : filters) {
    if (filter.matches(owner, key, creator, mimetype)) return true;
  }
  return false;
}

}  // namespace peis::view
