// The key registry on SQLite, and its YAML seed (yaml-cpp).
#include "key_registry.h"

#include <sqlite3.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "peis/error.h"
#include "peis/key.h"
#include "yaml_error.h"

namespace peis::bridge {
namespace {

[[noreturn]] void fail(const std::string& origin, const YAML::Node& node, const std::string& why) {
  failAt(origin, node, why);
}

// An integer in [low, high] written in decimal.
std::optional<long> integer(const std::string& text, long low, long high) {
  if (text.empty() || text.size() > 6) return std::nullopt;
  long value = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + (c - '0');
  }
  if (value < low || value > high) return std::nullopt;
  return value;
}

[[noreturn]] void dbFail(const std::string& path, sqlite3* db, const std::string& what) {
  throw Error(ErrorCode::InvalidConfig, "key registry " + path + ": " + what + ": " +
                                            (db != nullptr ? sqlite3_errmsg(db) : "out of memory"));
}

// A prepared statement that finalizes itself.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& path, const char* sql) : db_(db), path_(path) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) dbFail(path, db, sql);
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  sqlite3_stmt* get() { return stmt_; }
  // Steps once; true while there is a row.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    dbFail(path_, db_, "query failed");
  }

 private:
  sqlite3* db_;
  const std::string& path_;
  sqlite3_stmt* stmt_ = nullptr;
};

void exec(sqlite3* db, const std::string& path, const char* sql) {
  char* message = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string why = message != nullptr ? message : "unknown error";
    sqlite3_free(message);
    throw Error(ErrorCode::InvalidConfig, "key registry " + path + ": " + why);
  }
}

}  // namespace

std::optional<std::string> registryNameProblem(std::string_view name) {
  if (auto problem = keyProblem(name)) return problem;
  if (name.find('.') != std::string_view::npos)
    return std::string("a name is one key part (no '.')");
  if (name.front() == '#') return std::string("'#' starts a raw index, not a name");
  return std::nullopt;
}

RegistrySeed parseRegistrySeed(const std::string& yamlText, const std::string& origin) {
  const YAML::Node root = loadYaml(yamlText, origin);
  RegistrySeed seed;
  if (!root || root.IsNull()) return seed;
  if (!root.IsMap()) fail(origin, root, "the seed must be a mapping with 'keys' and 'nodes'");
  for (const auto& item : root) {
    const auto section = item.first.as<std::string>();
    if (section == "descriptors") continue;  // the nodes' descriptors (node_descriptors.h)
    if (section != "keys" && section != "nodes")
      fail(origin, item.first, "unknown key '" + section + "' (known: descriptors, keys, nodes)");
    if (item.second.IsNull()) continue;
    if (!item.second.IsMap()) fail(origin, item.second, "'" + section + "' must be a mapping");
  }
  std::set<KeyIndex> indexes;
  std::set<std::string> names;
  for (const auto& item : root["keys"]) {
    if (!item.second.IsScalar()) fail(origin, item.second, "a key's index must be a number");
    const auto name = item.first.as<std::string>();
    if (auto problem = registryNameProblem(name))
      fail(origin, item.first, "key name '" + name + "': " + *problem);
    const auto index = integer(item.second.as<std::string>(), 1, 65535);
    if (!index)
      fail(origin, item.second, "the index of '" + name + "' must be a whole number in 1..65535");
    if (!names.insert(name).second) fail(origin, item.first, "key '" + name + "' is given twice");
    if (!indexes.insert(static_cast<KeyIndex>(*index)).second)
      fail(origin, item.second, "index " + std::to_string(*index) + " is given twice");
    seed.keys.emplace_back(name, static_cast<KeyIndex>(*index));
  }
  for (const auto& item : root["nodes"]) {
    const auto id = integer(item.first.as<std::string>(), 1, 0xFFFE);
    if (!id) fail(origin, item.first, "a tiny node id must be a whole number in 1..65534");
    if (!item.second.IsScalar()) fail(origin, item.second, "a node's name must be a plain value");
    const auto name = item.second.as<std::string>();
    if (auto problem = nameProblem(name))
      fail(origin, item.second, "node name '" + name + "': " + *problem);
    if (seed.nodeNames.count(static_cast<std::uint16_t>(*id)))
      fail(origin, item.first, "tiny node " + std::to_string(*id) + " is given twice");
    for (const auto& [other, otherName] : seed.nodeNames)
      if (otherName == name)
        fail(origin, item.second,
             "tiny nodes " + std::to_string(other) + " and " + std::to_string(*id) +
                 " would both be PEIS '" + name + "'");
    seed.nodeNames[static_cast<std::uint16_t>(*id)] = name;
  }
  return seed;
}

RegistrySeed loadRegistrySeed(const std::string& path) {
  std::ifstream in(path);
  // A directory opens as a stream on Linux but reads as nothing.
  std::error_code ignored;
  if (!in || std::filesystem::is_directory(path, ignored))
    throw Error(ErrorCode::InvalidConfig, path + ": cannot read the key seed file");
  std::ostringstream text;
  text << in.rdbuf();
  return parseRegistrySeed(text.str(), path);
}

KeyRegistry::KeyRegistry(const std::string& path) : path_(path) {
  if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) !=
      SQLITE_OK) {
    const std::string why = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw Error(ErrorCode::InvalidConfig, "key registry " + path + ": cannot open: " + why);
  }
  try {
    sqlite3_busy_timeout(db_, 2000);
    exec(db_, path_,
         "CREATE TABLE IF NOT EXISTS peis_tiny_keys ("
         " name TEXT PRIMARY KEY NOT NULL,"
         " idx INTEGER UNIQUE NOT NULL CHECK (idx BETWEEN 1 AND 65535))");
    exec(db_, path_, "CREATE TABLE IF NOT EXISTS peis_tiny_radio_counter (value INTEGER NOT NULL)");
    Statement all(db_, path_, "SELECT name, idx FROM peis_tiny_keys");
    while (all.step()) {
      const auto* text = sqlite3_column_text(all.get(), 0);
      const auto index = sqlite3_column_int64(all.get(), 1);
      const std::string name = text != nullptr ? reinterpret_cast<const char*>(text) : "";
      // The table's constraints say this; a table made elsewhere may lack them.
      if (registryNameProblem(name) || index < 1 || index > 65535 || byName_.count(name) != 0 ||
          byIndex_.count(static_cast<KeyIndex>(index)) != 0)
        throw Error(ErrorCode::InvalidConfig, "key registry " + path_ + ": corrupt entry '" + name +
                                                  "' = " + std::to_string(index));
      byName_[name] = static_cast<KeyIndex>(index);
      byIndex_[static_cast<KeyIndex>(index)] = name;
    }
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

KeyRegistry::~KeyRegistry() { sqlite3_close(db_); }

KeyRegistry::KeyRegistry(KeyRegistry&& other) noexcept
    : path_(std::move(other.path_)),
      db_(std::exchange(other.db_, nullptr)),
      byName_(std::move(other.byName_)),
      byIndex_(std::move(other.byIndex_)) {}

KeyRegistry& KeyRegistry::operator=(KeyRegistry&& other) noexcept {
  if (this != &other) {
    sqlite3_close(db_);
    path_ = std::move(other.path_);
    db_ = std::exchange(other.db_, nullptr);
    byName_ = std::move(other.byName_);
    byIndex_ = std::move(other.byIndex_);
  }
  return *this;
}

void KeyRegistry::applySeed(const RegistrySeed& seed) {
  std::vector<std::pair<std::string, KeyIndex>> missing;
  for (const auto& [name, index] : seed.keys) {
    const auto known = find(name);
    if (known && *known == index) continue;
    if (known)
      throw Error(ErrorCode::InvalidConfig,
                  "key registry " + path_ + ": the seed gives '" + name + "' index " +
                      std::to_string(index) + " but the registry gave it " +
                      std::to_string(*known) + " (an index never changes)");
    if (auto holder = nameOf(index))
      throw Error(ErrorCode::InvalidConfig, "key registry " + path_ + ": the seed gives index " +
                                                std::to_string(index) + " to '" + name +
                                                "' but the registry gave it to '" + *holder + "'");
    missing.emplace_back(name, index);
  }
  if (missing.empty()) return;
  exec(db_, path_, "BEGIN");
  try {
    for (const auto& [name, index] : missing) insert(name, index);
    exec(db_, path_, "COMMIT");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    for (const auto& [name, index] : missing) {
      byName_.erase(name);
      byIndex_.erase(index);
    }
    throw;
  }
}

std::optional<KeyIndex> KeyRegistry::find(std::string_view name) const {
  auto it = byName_.find(name);
  if (it == byName_.end()) return std::nullopt;
  return it->second;
}

std::optional<std::string> KeyRegistry::nameOf(KeyIndex index) const {
  auto it = byIndex_.find(index);
  if (it == byIndex_.end()) return std::nullopt;
  return it->second;
}

KeyIndex KeyRegistry::intern(std::string_view name) {
  if (auto known = find(name)) return *known;
  if (auto problem = registryNameProblem(name))
    throw Error(ErrorCode::InvalidKey,
                "'" + std::string(name) + "' cannot be a tiny key: " + *problem);
  long next = byIndex_.empty() ? 1 : static_cast<long>(byIndex_.rbegin()->first) + 1;
  if (next > 65535) {  // the top is taken: the lowest gap
    next = 1;
    for (const auto& [index, _] : byIndex_) {
      if (index != next) break;
      ++next;
    }
    if (next > 65535) throw Error(ErrorCode::Refused, "the key registry has no free index left");
  }
  insert(std::string(name), static_cast<KeyIndex>(next));
  return static_cast<KeyIndex>(next);
}

void KeyRegistry::insert(const std::string& name, KeyIndex index) {
  Statement add(db_, path_, "INSERT INTO peis_tiny_keys (name, idx) VALUES (?1, ?2)");
  sqlite3_bind_text(add.get(), 1, name.c_str(), static_cast<int>(name.size()), SQLITE_TRANSIENT);
  sqlite3_bind_int(add.get(), 2, index);
  add.step();
  byName_[name] = index;
  byIndex_[index] = name;
}

std::vector<std::pair<std::string, KeyIndex>> KeyRegistry::entries() const {
  std::vector<std::pair<std::string, KeyIndex>> out;
  for (const auto& [index, name] : byIndex_) out.emplace_back(name, index);
  return out;
}

std::uint32_t KeyRegistry::radioCounter() const {
  Statement read(db_, path_, "SELECT max(value) FROM peis_tiny_radio_counter");
  if (!read.step() || sqlite3_column_type(read.get(), 0) == SQLITE_NULL) return 0;
  return static_cast<std::uint32_t>(sqlite3_column_int64(read.get(), 0));
}

void KeyRegistry::setRadioCounter(std::uint32_t value) {
  exec(db_, path_, "BEGIN");
  try {
    exec(db_, path_, "DELETE FROM peis_tiny_radio_counter");
    Statement add(db_, path_, "INSERT INTO peis_tiny_radio_counter (value) VALUES (?1)");
    sqlite3_bind_int64(add.get(), 1, value);
    add.step();
    exec(db_, path_, "COMMIT");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

}  // namespace peis::bridge
