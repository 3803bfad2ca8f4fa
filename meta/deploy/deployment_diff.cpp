// Desired tuples of a configuration, the diff against the ecology, and the
// text of the records a deployment keeps (config.owned, config.lock).
#include "deploy/deployment_diff.h"

#include <algorithm>
#include <charconv>
#include <sstream>

#include "peis/conventions.h"

namespace peis::meta {
namespace {

bool endsWith(const std::string& text, std::string_view suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

template <typename T>
bool parseNumber(std::string_view text, T& value) {
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && ptr == text.data() + text.size();
}

}  // namespace

std::set<int> DesiredState::peis() const {
  std::set<int> ids;
  for (const auto& [id, tuples] : this->tuples) ids.insert(id);
  return ids;
}

DesiredState desiredState(const Configuration& configuration) {
  DesiredState state;
  for (const auto& link : configuration.links) {
    state.names[link.consumerId] = link.consumerPeis;
    state.names[link.producerId] = link.producerPeis;
    state.tuples[link.consumerId][link.consumerKey] =
        std::to_string(link.producerId) + "." + link.producerKey;
  }
  // Activations: per PEIS and actuator, `on` or the instances' bindings.
  std::map<std::pair<int, std::string>, std::set<std::string>> bindings;
  std::set<std::pair<int, std::string>> plainOn;
  for (const auto& instance : configuration.instances) {
    state.names[instance.peisId] = instance.peis;
    if (instance.activation.empty()) continue;
    const auto where = std::make_pair(instance.peisId, instance.activation);
    std::string text;
    for (const auto& [var, value] : instance.binding) {
      if (var == kSelfVariable) continue;
      const auto name = isVariable(var) ? var.substr(1) : var;
      text += (text.empty() ? "" : ",") + name + "=" + value;
    }
    if (text.empty()) {
      plainOn.insert(where);
    } else {
      bindings[where].insert(text);
    }
    state.tuples[instance.peisId];  // the PEIS takes part
  }
  for (const auto& where : plainOn) {
    state.tuples[where.first][conventions::reqStateKey(where.second)] =
        std::string(conventions::kActivationOn);
  }
  for (const auto& [where, set] : bindings) {
    if (plainOn.count(where)) continue;
    std::string value;
    for (const auto& b : set) value += (value.empty() ? "" : " ") + b;
    state.tuples[where.first][conventions::reqStateKey(where.second)] = value;
  }
  // A PEIS with only a producer role and no activation has nothing to write.
  for (auto it = state.tuples.begin(); it != state.tuples.end();) {
    it = it->second.empty() ? state.tuples.erase(it) : std::next(it);
  }
  return state;
}

bool isMetaKey(const std::string& key) { return !conventions::inputOfMetaKey(key).empty(); }

std::string switchedOffValue(const std::string& key) {
  if (endsWith(key, conventions::kReqState)) return std::string(conventions::kActivationOff);
  return "";
}

std::vector<PeisChanges> diffDeployment(
    const DesiredState& desired, const std::map<int, std::set<std::string>>& owned,
    const CurrentValue& current, const std::function<std::string(const std::string&)>& canonical) {
  std::set<int> all = desired.peis();
  for (const auto& [id, keys] : owned) all.insert(id);
  std::vector<PeisChanges> changes;
  for (int id : all) {
    PeisChanges c;
    c.peis = id;
    if (auto n = desired.names.find(id); n != desired.names.end()) c.name = n->second;
    if (auto o = owned.find(id); o != owned.end()) c.ownedBefore = o->second;
    std::map<std::string, std::string> wanted;
    if (auto d = desired.tuples.find(id); d != desired.tuples.end()) wanted = d->second;
    for (const auto& [key, value] : wanted) c.ownedAfter.insert(key);
    for (const auto& key : c.ownedBefore) {
      if (!wanted.count(key)) wanted[key] = switchedOffValue(key);
    }
    for (const auto& [key, value] : wanted) {
      auto now = current(id, key);
      auto same = [&] {
        if (!now) return false;
        if (isMetaKey(key) && canonical) return canonical(*now) == canonical(value);
        return *now == value;
      }();
      // A key to switch off that is not there (its PEIS restarted) stays absent.
      if (!now && !c.ownedAfter.count(key)) same = true;
      if (!same) c.writes.push_back(TupleWrite{id, key, value, now});
    }
    if (!c.writes.empty() || c.recordChanges()) changes.push_back(std::move(c));
  }
  return changes;
}

std::string OwnedRecord::format() const {
  if (keys.empty()) return "";
  std::string text = std::to_string(generation) + " " + std::to_string(deployer) + "\n";
  for (const auto& k : keys) text += k + "\n";
  return text;
}

OwnedRecord OwnedRecord::parse(const std::string& text) {
  OwnedRecord record;
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line)) return record;
  std::istringstream header(line);
  std::string generation, deployer;
  header >> generation >> deployer;
  parseNumber(generation, record.generation);
  parseNumber(deployer, record.deployer);
  while (std::getline(in, line)) {
    if (!line.empty() && line.find(' ') == std::string::npos) record.keys.insert(line);
  }
  return record;
}

std::string LockLine::format() const {
  return std::to_string(generation) + " " + std::to_string(holder) + " " +
         (deploying ? "deploying" : "done");
}

std::optional<LockLine> LockLine::parse(const std::string& line) {
  std::istringstream in(line);
  std::string generation, holder, state, extra;
  if (!(in >> generation >> holder >> state) || (in >> extra)) return std::nullopt;
  LockLine l;
  if (!parseNumber(generation, l.generation) || !parseNumber(holder, l.holder)) return std::nullopt;
  if (state != "deploying" && state != "done") return std::nullopt;
  l.deploying = state == "deploying";
  return l;
}

std::optional<LockLine> lastLockLine(const std::string& text) {
  auto end = text.find_last_not_of('\n');
  if (end == std::string::npos) return std::nullopt;
  auto start = text.rfind('\n', end);
  start = start == std::string::npos ? 0 : start + 1;
  return LockLine::parse(text.substr(start, end - start + 1));
}

std::size_t lineCount(const std::string& text) {
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) +
         (text.empty() || text.back() == '\n' ? 0 : 1);
}

}  // namespace peis::meta
