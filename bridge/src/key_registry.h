// The tinybridge's key registry: string key part <-> integer sub-key index,
// kept in SQLite so an index never changes once given, seeded from a YAML
// file (tiny-peis-kernel.txt section V: LightValue = 42, TiltValue = 43).
//
// A name is one key part (no '.'), not starting with '#': "#N" is how a
// full PEIS writes the raw index N, and how an index without a name shows.
// Indexes are 1..65535. Methods throw peis::Error: InvalidConfig for a
// broken file or a seed that contradicts the registry, InvalidKey for a bad
// name, Refused when all 65535 indexes are taken.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

struct sqlite3;

namespace peis::bridge {

using KeyIndex = std::uint16_t;

// The seed file: key names with their indexes, and names for tiny nodes
// (and the nodes' functionality descriptors, read by node_descriptors.h).
//   keys:
//     LightValue: 42
//   nodes:
//     3: plant
struct RegistrySeed {
  std::vector<std::pair<std::string, KeyIndex>> keys;
  std::map<std::uint16_t, std::string> nodeNames;
};

// Parses a seed; Error(InvalidConfig) naming origin:line for every problem
// (broken YAML, unknown top-level keys, an index out of 1..65535, a name
// given twice, an index given twice, a bad node id or PEIS name).
RegistrySeed parseRegistrySeed(const std::string& yamlText, const std::string& origin);
RegistrySeed loadRegistrySeed(const std::string& path);

// Why `name` cannot be a registry name, or nullopt.
std::optional<std::string> registryNameProblem(std::string_view name);

class KeyRegistry {
 public:
  // Opens or creates the registry database at `path` (":memory:" for a
  // throw-away one). Error(InvalidConfig) if it is not a registry.
  explicit KeyRegistry(const std::string& path);
  ~KeyRegistry();
  KeyRegistry(KeyRegistry&&) noexcept;
  KeyRegistry& operator=(KeyRegistry&&) noexcept;

  // Adds the seed's keys. An entry already present with the same index is
  // fine; a name or index that the registry gives otherwise is an error
  // (indexes never change), and nothing of the seed is applied then.
  void applySeed(const RegistrySeed& seed);

  std::optional<KeyIndex> find(std::string_view name) const;
  std::optional<std::string> nameOf(KeyIndex index) const;
  // The index of `name`, given now (the lowest free one above every index
  // in use) and persisted if it had none.
  KeyIndex intern(std::string_view name);
  // Every (name, index), ordered by index.
  std::vector<std::pair<std::string, KeyIndex>> entries() const;
  // A secured radio's frame counter, kept here across restarts (0 at first).
  std::uint32_t radioCounter() const;
  void setRadioCounter(std::uint32_t value);
  const std::string& path() const { return path_; }

 private:
  void insert(const std::string& name, KeyIndex index);
  std::string path_;
  sqlite3* db_ = nullptr;
  std::map<std::string, KeyIndex, std::less<>> byName_;
  std::map<KeyIndex, std::string> byIndex_;
};

}  // namespace peis::bridge
