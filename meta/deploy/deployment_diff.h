// What deploying a configuration writes, as pure functions (no kernel): the
// tuples a configuration wants on each PEIS (each link's meta tuple
// `mi-…` = `PRODUCER_ID.KEY`, each activation actuator's `<act>.reqState`),
// and the difference between that and what the ecology holds now, given the
// keys the previous configuration wrote on each PEIS (its `config.owned`
// record): the writes that change something, and for a key the old
// configuration wrote but the new one does not want, its "switched off"
// value (an empty meta tuple, `off`). docs/configuration.md, "Deployment".
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "peis/meta/configuration.h"

namespace peis::meta {

// The tuples a configuration sets: PEIS id -> key -> value.
struct DesiredState {
  std::map<int, std::map<std::string, std::string>> tuples;
  std::map<int, std::string> names;  // PEIS id -> name, for messages
  std::set<int> peis() const;
  bool operator==(const DesiredState&) const = default;
};

// Links become `mi-…` = `<producer id>.<producer key>`; every active
// instance with an activation makes `<activation>.reqState` `on`, or, for
// instances with variables, their bindings (`robot=vac,a=cam1`, several
// separated by one space, sorted).
DesiredState desiredState(const Configuration& configuration);

// The value that switches a key off when no configuration wants it: an
// empty meta tuple for `mi-…`, `off` for `….reqState`.
std::string switchedOffValue(const std::string& key);
bool isMetaKey(const std::string& key);

struct TupleWrite {
  int peis = 0;
  std::string key;
  std::string value;
  std::optional<std::string> previous;  // the value before (nothing: absent)
  bool operator==(const TupleWrite&) const = default;
};

// The changes on one PEIS.
struct PeisChanges {
  int peis = 0;
  std::string name;
  std::vector<TupleWrite> writes;     // ordered by key
  std::set<std::string> ownedBefore;  // its config.owned record now
  std::set<std::string> ownedAfter;   // the keys the new configuration wants there
  bool recordChanges() const { return ownedBefore != ownedAfter; }
  bool operator==(const PeisChanges&) const = default;
};

// What is on the PEIS now: the value of a key (nothing: absent or unknown).
using CurrentValue = std::function<std::optional<std::string>(int peis, const std::string& key)>;

// For every PEIS in `desired` or in `owned` (PEIS -> its config.owned keys):
// the writes that make the ecology hold `desired`, and switch off what the
// owned records name and `desired` does not. A value already there is not
// written again (so deploying twice writes nothing). `canonical` turns a
// meta tuple's data into the `ID.KEY` form before comparing (a meta tuple
// written as `name.key` points at the same tuple as `id.key`). PEIS with
// nothing to change are left out.
std::vector<PeisChanges> diffDeployment(
    const DesiredState& desired, const std::map<int, std::set<std::string>>& owned,
    const CurrentValue& current,
    const std::function<std::string(const std::string&)>& canonical = {});

// --- the records a deployment keeps on each PEIS it touches -----------------------

// `config.owned`: first line `<generation> <deployer id>`, then one key per
// line that the configuration wrote on this PEIS. Empty: nothing.
struct OwnedRecord {
  std::uint64_t generation = 0;
  int deployer = 0;
  std::set<std::string> keys;
  std::string format() const;
  static OwnedRecord parse(const std::string& text);  // lenient: bad lines are skipped
  bool operator==(const OwnedRecord&) const = default;
};

// `config.lock`: lines `<generation> <holder id> deploying|done`, appended
// with compare-and-set (`append … ifSeqno`); the last line says who holds it.
struct LockLine {
  std::uint64_t generation = 0;
  int holder = 0;
  bool deploying = false;
  std::string format() const;
  static std::optional<LockLine> parse(const std::string& line);
  bool operator==(const LockLine&) const = default;
};
// The last line of a lock tuple's text, parsed (nothing: free, or unreadable).
std::optional<LockLine> lastLockLine(const std::string& text);
std::size_t lineCount(const std::string& text);

}  // namespace peis::meta
