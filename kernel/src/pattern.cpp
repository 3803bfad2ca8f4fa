// Abstract-tuple matching (docs/tuple-model.md, "Matching").
#include "peis/pattern.h"

#include "peis/error.h"
#include "peis/key.h"

namespace peis {

Pattern::Pattern() : key_("**"), parts_{"**"}, hasWildcard_(true) {}

Pattern::Pattern(std::string_view keyPattern, std::optional<PeisId> owner)
    : owner_(owner), key_(keyPattern) {
  if (auto problem = keyPatternProblem(keyPattern)) {
    throw Error(ErrorCode::InvalidKey,
                "invalid key pattern '" + std::string(keyPattern.substr(0, 64)) + "': " + *problem);
  }
  if (owner && !isValidPeisId(*owner)) {
    throw Error(ErrorCode::InvalidArgument, "invalid owner id " + std::to_string(*owner));
  }
  for (auto part : splitKey(keyPattern)) {
    parts_.emplace_back(part);
    hasWildcard_ = hasWildcard_ || part == "*" || part == "**";
  }
}

Pattern Pattern::parse(std::string_view text) {
  const auto dot = text.find('.');
  if (dot == std::string_view::npos) {
    throw Error(ErrorCode::InvalidKey, "invalid pattern '" + std::string(text.substr(0, 64)) +
                                           "': expected OWNER.KEY where OWNER is an id or *");
  }
  const auto owner = text.substr(0, dot);
  if (owner == "*") return Pattern(text.substr(dot + 1));
  const auto id = parsePeisId(owner);
  if (!id) {
    throw Error(ErrorCode::InvalidName, "invalid pattern owner '" +
                                            std::string(owner.substr(0, 64)) +
                                            "': expected a PEIS id or *");
  }
  return Pattern(text.substr(dot + 1), *id);
}

Pattern Pattern::exact(PeisId owner, std::string_view key) {
  validateKey(key);
  return Pattern(key, owner);
}

Pattern& Pattern::owner(PeisId id) {
  owner_ = id;
  return *this;
}
Pattern& Pattern::creator(PeisId id) {
  creator_ = id;
  return *this;
}
Pattern& Pattern::mimetype(std::string type) {
  mimetype_ = std::move(type);
  return *this;
}
Pattern& Pattern::data(std::string bytes) {
  data_ = std::move(bytes);
  return *this;
}

bool Pattern::matchesKey(std::string_view key) const {
  if (!hasWildcard_) return key == key_;
  std::size_t start = 0;
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    if (start > key.size()) return false;  // key ran out of parts
    if (parts_[i] == "**") return start < key.size();
    auto dot = key.find('.', start);
    const auto end = dot == std::string_view::npos ? key.size() : dot;
    const auto part = key.substr(start, end - start);
    if (part.empty() || (parts_[i] != "*" && part != parts_[i])) return false;
    start = end + 1;
  }
  return start == key.size() + 1;  // every key part consumed
}

bool Pattern::matchesOwnerAndKey(PeisId owner, std::string_view key) const {
  return (!owner_ || *owner_ == owner) && matchesKey(key);
}

bool Pattern::matches(const Tuple& tuple) const {
  return matchesOwnerAndKey(tuple.owner, tuple.key) && matchesBeyondOwnerAndKey(tuple);
}

bool Pattern::matchesBeyondOwnerAndKey(const Tuple& tuple) const {
  return (!creator_ || *creator_ == tuple.creator) &&
         (!mimetype_ || *mimetype_ == tuple.mimetype) && (!data_ || *data_ == tuple.data);
}

bool Pattern::isExact() const {
  return owner_.has_value() && !hasWildcard_ && !creator_ && !mimetype_ && !data_;
}

std::string Pattern::str() const {
  return (owner_ ? std::to_string(*owner_) : std::string("*")) + "." + key_;
}

}  // namespace peis
