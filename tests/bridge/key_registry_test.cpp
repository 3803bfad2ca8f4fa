// Unit tests of the tinybridge's key registry and its YAML seed
// (bridge/src/key_registry.h).
#include "key_registry.h"

#include <sqlite3.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "node_descriptors.h"
#include "peis/error.h"
#include "support/error_matchers.h"
#include "support/temp_dir.h"

using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using peis::Error;
using peis::ErrorCode;
using peis::bridge::KeyIndex;
using peis::bridge::KeyRegistry;
using peis::bridge::RegistrySeed;
using peis::test::HasCode;
using peis::test::TempDir;

namespace {

using Entries = std::vector<std::pair<std::string, KeyIndex>>;

RegistrySeed seedOf(Entries keys) {
  RegistrySeed seed;
  seed.keys = std::move(keys);
  return seed;
}

// The index `seed` gives `name`, or 0.
KeyIndex indexIn(const RegistrySeed& seed, const std::string& name) {
  for (const auto& [key, index] : seed.keys)
    if (key == name) return index;
  return 0;
}

// Parses `text`, which must fail with InvalidConfig; returns the message.
std::string seedFailure(const std::string& text, const std::string& origin = "seed.yaml") {
  try {
    peis::bridge::parseRegistrySeed(text, origin);
  } catch (const Error& e) {
    CHECK(e.code() == ErrorCode::InvalidConfig);
    return e.what();
  }
  FAIL("expected a peis::Error for:\n" << text);
  return {};
}

// The peis::Error that `f` throws, or nothing.
template <typename F>
std::optional<Error> errorFrom(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  return std::nullopt;
}

// Runs `sql` on the SQLite file at `path`, outside any KeyRegistry.
void runSql(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(path.c_str(), &db) == SQLITE_OK);
  char* message = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  const std::string why = message != nullptr ? message : "";
  sqlite3_free(message);
  sqlite3_close(db);
  INFO(sql << ": " << why);
  REQUIRE(rc == SQLITE_OK);
}

// Opening the registry at `path` must fail with InvalidConfig; the message.
std::string openFailure(const std::string& path) {
  try {
    KeyRegistry registry(path);
  } catch (const Error& e) {
    CHECK(e.code() == ErrorCode::InvalidConfig);
    return e.what();
  }
  FAIL("opening " << path << " did not fail");
  return {};
}

}  // namespace

// ---------------------------------------------------------------------------
// The seed

TEST_CASE("the repository's bridge/keys.yaml parses with the documented indexes",
          "[unit][bridge][registry]") {
  const std::string path = std::string(PEIS_SOURCE_DIR) + "/bridge/keys.yaml";
  const auto seed = peis::bridge::loadRegistrySeed(path);
  CHECK(indexIn(seed, "LightValue") == 42);
  CHECK(indexIn(seed, "TiltValue") == 43);
  REQUIRE(seed.nodeNames.count(3) == 1);
  CHECK(seed.nodeNames.at(3) == "plant");

  KeyRegistry registry(":memory:");
  registry.applySeed(seed);
  CHECK(registry.find("LightValue") == KeyIndex{42});
  CHECK(registry.nameOf(43) == "TiltValue");
  CHECK(registry.entries().size() == seed.keys.size());
}

TEST_CASE("the seed's node descriptors read inline or from a file with file:line errors",
          "[unit][bridge][registry]") {
  const auto repository =
      peis::bridge::loadNodeDescriptors(std::string(PEIS_SOURCE_DIR) + "/bridge/keys.yaml");
  REQUIRE(repository.count(5) == 1);
  CHECK(repository.at(5).functionalities.at(0).outputs.at(0).key == "Weight");
  TempDir dir;
  dir.write("scale.yaml",
            "component: scale\nfunctionalities:\n  - {name: weigh, outputs: "
            "[{name: w, type: weight, key: Weight}]}\n");
  const auto fromFile = peis::bridge::loadNodeDescriptors(
      dir.write("seed.yaml", "keys:\n  Weight: 44\ndescriptors:\n  5: scale.yaml\n"));
  CHECK(fromFile.at(5).component == "scale");
  auto failure = [](const std::string& text) {
    try {
      peis::bridge::parseNodeDescriptors(text, "s.yaml");
    } catch (const peis::Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK_THAT(failure("descriptors:\n  x: {component: a}\n"),
             StartsWith("s.yaml:2:") && Contains("1..65534"));
  CHECK_THAT(failure("descriptors:\n  3:\n    component: a\n    bogus: 1\n"),
             StartsWith("s.yaml:4:") && Contains("unknown key 'bogus'"));
  CHECK_THAT(failure("descriptors:\n  3: missing.yaml\n"),
             StartsWith("s.yaml:2:") && Contains("in the descriptor"));
  CHECK_THAT(failure("descriptors: [a]\n"), Contains("must be a mapping"));
  CHECK(peis::bridge::parseNodeDescriptors("keys:\n  A: 1\n", "s.yaml").empty());
}

TEST_CASE("parseRegistrySeed reads keys in file order and node names", "[unit][bridge][registry]") {
  const auto seed = peis::bridge::parseRegistrySeed(
      "keys:\n  Zeta: 9\n  Alpha: 1\n  Mid: 65535\nnodes:\n  3: plant\n  65534: far\n", "s.yaml");
  CHECK(seed.keys == Entries{{"Zeta", 9}, {"Alpha", 1}, {"Mid", 65535}});
  CHECK(seed.nodeNames == std::map<std::uint16_t, std::string>{{3, "plant"}, {65534, "far"}});
}

TEST_CASE("an empty seed file gives an empty seed", "[unit][bridge][registry]") {
  SECTION("no text at all") {
    const auto seed = peis::bridge::parseRegistrySeed("", "empty.yaml");
    CHECK(seed.keys.empty());
    CHECK(seed.nodeNames.empty());
  }
  SECTION("only a comment") {
    const auto seed = peis::bridge::parseRegistrySeed("# nothing yet\n", "c.yaml");
    CHECK(seed.keys.empty());
    CHECK(seed.nodeNames.empty());
  }
  SECTION("empty sections") {
    const auto seed = peis::bridge::parseRegistrySeed("keys:\nnodes:\n", "e.yaml");
    CHECK(seed.keys.empty());
    CHECK(seed.nodeNames.empty());
  }
  SECTION("an empty file on disk") {
    TempDir dir;
    const auto seed = peis::bridge::loadRegistrySeed(dir.write("empty.yaml", ""));
    CHECK(seed.keys.empty());
    CHECK(seed.nodeNames.empty());
  }
}

TEST_CASE("broken YAML in a seed is InvalidConfig with origin and line",
          "[unit][bridge][registry]") {
  CHECK_THAT(seedFailure("keys: [unclosed\n"), StartsWith("seed.yaml:") && Contains("broken YAML"));
  CHECK_THAT(seedFailure("keys:\n  A: 1\n  B: {open: 2\n"),
             StartsWith("seed.yaml:") && Contains("broken YAML"));
  CHECK_THAT(seedFailure("keys:\n  A: 1\n bad: [\n", "f.yaml"), StartsWith("f.yaml:"));
}

TEST_CASE("a seed's top level is a mapping of keys and nodes only", "[unit][bridge][registry]") {
  SECTION("a list") {
    CHECK_THAT(seedFailure("- keys\n- nodes\n"), StartsWith("seed.yaml:1:") && Contains("mapping"));
  }
  SECTION("plain text") { CHECK_THAT(seedFailure("just text\n"), Contains("mapping")); }
  SECTION("an unknown top-level key") {
    CHECK_THAT(seedFailure("keys:\n  A: 1\ncolours: 2\n"),
               StartsWith("seed.yaml:3:") && Contains("'colours'") && Contains("keys, nodes"));
  }
  SECTION("keys that is not a mapping") {
    CHECK_THAT(seedFailure("keys: [A, B]\n"),
               StartsWith("seed.yaml:1:") && Contains("'keys' must be a mapping"));
  }
  SECTION("nodes that is not a mapping") {
    CHECK_THAT(seedFailure("keys:\n  A: 1\nnodes: plant\n"),
               StartsWith("seed.yaml:3:") && Contains("'nodes' must be a mapping"));
  }
}

TEST_CASE("a key's index must be a whole number in 1..65535", "[unit][bridge][registry]") {
  const std::string head = "keys:\n  Good: 1\n  Bad: ";
  for (const std::string bad : {"0", "65536", "-1", "abc", "4.5", "0x2A", "99999999"}) {
    INFO("index " << bad);
    CHECK_THAT(seedFailure(head + bad + "\n"),
               StartsWith("seed.yaml:3:") && Contains("'Bad'") && Contains("1..65535"));
  }
  SECTION("a list") {
    CHECK_THAT(seedFailure(head + "[1, 2]\n"), StartsWith("seed.yaml:3:") && Contains("number"));
  }
  SECTION("a mapping") {
    CHECK_THAT(seedFailure(head + "{a: 1}\n"), StartsWith("seed.yaml:3:") && Contains("number"));
  }
  SECTION("nothing") { CHECK_THAT(seedFailure(head + "\n"), Contains("number")); }
  SECTION("the bounds themselves are fine") {
    const auto seed = peis::bridge::parseRegistrySeed("keys:\n  Low: 1\n  High: 65535\n", "b.yaml");
    CHECK(seed.keys == Entries{{"Low", 1}, {"High", 65535}});
  }
}

TEST_CASE("a key name must be one key part not starting with '#'", "[unit][bridge][registry]") {
  const std::string head = "keys:\n  Good: 1\n  ";
  for (const std::string bad : {"a.b", "x*", "a=b", "two words", "#5"}) {
    INFO("name " << bad);
    CHECK_THAT(seedFailure(head + "\"" + bad + "\": 2\n"),
               StartsWith("seed.yaml:3:") && Contains("'" + bad + "'"));
  }
}

TEST_CASE("a key name or an index given twice in a seed is refused", "[unit][bridge][registry]") {
  SECTION("a name") {
    CHECK_THAT(seedFailure("keys:\n  A: 1\n  B: 2\n  A: 3\n"),
               StartsWith("seed.yaml:4:") && Contains("'A'") && Contains("twice"));
  }
  SECTION("an index") {
    CHECK_THAT(seedFailure("keys:\n  A: 7\n  B: 8\n  C: 7\n"),
               StartsWith("seed.yaml:4:") && Contains("index 7") && Contains("twice"));
  }
}

TEST_CASE("a tiny node id must be 1..65534 and its name a PEIS name", "[unit][bridge][registry]") {
  const std::string head = "nodes:\n  3: plant\n  ";
  for (const std::string bad : {"0", "65535", "abc", "-3", "1.5"}) {
    INFO("node id " << bad);
    CHECK_THAT(seedFailure(head + bad + ": lamp\n"),
               StartsWith("seed.yaml:3:") && Contains("tiny node id"));
  }
  for (const std::string bad : {"a.b", "123", "two words", "x*"}) {
    INFO("node name " << bad);
    CHECK_THAT(seedFailure(head + "4: \"" + bad + "\"\n"),
               StartsWith("seed.yaml:3:") && Contains("'" + bad + "'"));
  }
  SECTION("a name that is not a plain value") {
    CHECK_THAT(seedFailure(head + "4: [a, b]\n"),
               StartsWith("seed.yaml:3:") && Contains("plain value"));
  }
}

TEST_CASE("loadRegistrySeed reads a file and names it in errors", "[unit][bridge][registry]") {
  TempDir dir;
  SECTION("a good file") {
    const auto seed = peis::bridge::loadRegistrySeed(
        dir.write("keys.yaml", "keys:\n  LightValue: 42\nnodes:\n  3: plant\n"));
    CHECK(seed.keys == Entries{{"LightValue", 42}});
    CHECK(seed.nodeNames.at(3) == "plant");
  }
  SECTION("a broken file") {
    const auto path = dir.write("broken.yaml", "keys:\n  A: 1\n  B: 0\n");
    REQUIRE_THROWS_MATCHES(peis::bridge::loadRegistrySeed(path), Error,
                           HasCode(ErrorCode::InvalidConfig));
    try {
      peis::bridge::loadRegistrySeed(path);
    } catch (const Error& e) {
      CHECK_THAT(e.what(), StartsWith(path + ":3:"));
    }
  }
  SECTION("a missing file") {
    const auto path = dir.file("missing.yaml");
    const auto error = errorFrom([&] { peis::bridge::loadRegistrySeed(path); });
    REQUIRE(error);
    CHECK(error->code() == ErrorCode::InvalidConfig);
    CHECK(std::string(error->what()) == path + ": cannot read the key seed file");
  }
  SECTION("a directory") {
    // Opening a directory as a stream succeeds on Linux; reading it does
    // not. It must not pass for an empty seed.
    REQUIRE_THROWS_MATCHES(peis::bridge::loadRegistrySeed(dir.path.string()), Error,
                           HasCode(ErrorCode::InvalidConfig));
  }
}

// ---------------------------------------------------------------------------
// The registry

TEST_CASE("a seeded registry keeps every index when reopened", "[unit][bridge][registry]") {
  TempDir dir;
  const auto path = dir.file("keys.db");
  const auto seed = seedOf({{"LightValue", 42}, {"TiltValue", 43}, {"Weight", 44}, {"Low", 2}});
  {
    KeyRegistry registry(path);
    CHECK(registry.path() == path);
    CHECK(registry.entries().empty());
    registry.applySeed(seed);
  }
  KeyRegistry again(path);
  CHECK(again.entries() ==
        Entries{{"Low", 2}, {"LightValue", 42}, {"TiltValue", 43}, {"Weight", 44}});
  CHECK(again.find("LightValue") == KeyIndex{42});
  CHECK(again.find("TiltValue") == KeyIndex{43});
  CHECK(again.nameOf(44) == "Weight");
  CHECK(again.nameOf(2) == "Low");

  SECTION("the same seed again changes nothing") {
    again.applySeed(seed);
    CHECK(again.entries().size() == 4);
  }
  SECTION("a seed with more keys adds only those") {
    again.applySeed(seedOf({{"LightValue", 42}, {"LampLevel", 45}}));
    CHECK(again.entries().size() == 5);
    KeyRegistry third(path);
    CHECK(third.find("LampLevel") == KeyIndex{45});
    CHECK(third.find("LightValue") == KeyIndex{42});
  }
}

TEST_CASE("intern gives a new name the next index above the highest, for good",
          "[unit][bridge][registry]") {
  TempDir dir;
  const auto path = dir.file("keys.db");
  {
    KeyRegistry registry(path);
    registry.applySeed(seedOf({{"A", 5}, {"LightValue", 42}, {"B", 7}}));
    CHECK(registry.intern("Fresh") == 43);  // above 42, not the gap at 1 or 6
    CHECK(registry.intern("Fresh") == 43);  // the same name, the same index
    CHECK(registry.intern("Other") == 44);
    CHECK(registry.intern("LightValue") == 42);  // a known name keeps its index
    CHECK(registry.find("Fresh") == KeyIndex{43});
    CHECK(registry.nameOf(44) == "Other");
  }
  KeyRegistry again(path);
  CHECK(again.find("Fresh") == KeyIndex{43});
  CHECK(again.find("Other") == KeyIndex{44});
  CHECK(again.intern("Fresh") == 43);
  CHECK(again.intern("Third") == 45);
  CHECK(
      again.entries() ==
      Entries{{"A", 5}, {"B", 7}, {"LightValue", 42}, {"Fresh", 43}, {"Other", 44}, {"Third", 45}});
}

TEST_CASE("intern in an empty registry starts at 1", "[unit][bridge][registry]") {
  KeyRegistry registry(":memory:");
  CHECK(registry.intern("First") == 1);
  CHECK(registry.intern("Second") == 2);
}

TEST_CASE("intern takes the lowest gap once 65535 is in use", "[unit][bridge][registry]") {
  KeyRegistry registry(":memory:");
  registry.applySeed(seedOf({{"One", 1}, {"Two", 2}, {"Top", 65535}}));
  CHECK(registry.intern("Next") == 3);
  CHECK(registry.intern("After") == 4);
}

TEST_CASE("intern is Refused when every index is taken", "[unit][bridge][registry]") {
  RegistrySeed all;
  for (long i = 1; i <= 65535; ++i)
    all.keys.emplace_back("k" + std::to_string(i), static_cast<KeyIndex>(i));
  KeyRegistry registry(":memory:");
  registry.applySeed(all);
  REQUIRE(registry.entries().size() == 65535);
  CHECK(registry.intern("k77") == 77);
  REQUIRE_THROWS_MATCHES(registry.intern("OneMore"), Error, HasCode(ErrorCode::Refused));
  CHECK_FALSE(registry.find("OneMore"));
}

TEST_CASE("find, nameOf and entries report what the registry holds", "[unit][bridge][registry]") {
  KeyRegistry registry(":memory:");
  CHECK(registry.entries().empty());
  CHECK_FALSE(registry.find("LightValue"));
  CHECK_FALSE(registry.nameOf(42));

  registry.applySeed(seedOf({{"Zeta", 900}, {"LightValue", 42}, {"Alpha", 7}}));
  CHECK(registry.find("LightValue") == KeyIndex{42});
  CHECK_FALSE(registry.find("lightvalue"));  // names are case-sensitive
  CHECK_FALSE(registry.find("Light"));
  CHECK(registry.nameOf(900) == "Zeta");
  CHECK_FALSE(registry.nameOf(43));
  CHECK_FALSE(registry.nameOf(0));
  CHECK(registry.entries() == Entries{{"Alpha", 7}, {"LightValue", 42}, {"Zeta", 900}});
}

TEST_CASE("a moved registry keeps its entries and its database", "[unit][bridge][registry]") {
  TempDir dir;
  const auto path = dir.file("keys.db");
  KeyRegistry first(path);
  first.applySeed(seedOf({{"LightValue", 42}}));
  KeyRegistry moved(std::move(first));
  CHECK(moved.find("LightValue") == KeyIndex{42});
  CHECK(moved.intern("Fresh") == 43);
  KeyRegistry assigned(":memory:");
  assigned = std::move(moved);
  CHECK(assigned.intern("Later") == 44);
  CHECK(assigned.path() == path);
  KeyRegistry again(path);
  CHECK(again.entries() == Entries{{"LightValue", 42}, {"Fresh", 43}, {"Later", 44}});
}

TEST_CASE("intern of a name that cannot be a registry name is InvalidKey",
          "[unit][bridge][registry]") {
  KeyRegistry registry(":memory:");
  for (const std::string bad : {"", "a.b", "x*", "a=b", "two words", "#5", "#"}) {
    INFO("name '" << bad << "'");
    REQUIRE_THROWS_MATCHES(registry.intern(bad), Error, HasCode(ErrorCode::InvalidKey));
  }
  CHECK(registry.entries().empty());
  CHECK(peis::bridge::registryNameProblem("LightValue") == std::nullopt);
  CHECK(peis::bridge::registryNameProblem("#5").has_value());
}

TEST_CASE("an index never changes: a contradicting seed is refused whole",
          "[unit][bridge][registry]") {
  TempDir dir;
  const auto path = dir.file("keys.db");
  KeyRegistry registry(path);
  registry.applySeed(seedOf({{"LightValue", 42}, {"TiltValue", 43}}));

  SECTION("a known name with another index") {
    const auto error = errorFrom([&] {
      registry.applySeed(seedOf({{"Fresh", 100}, {"LightValue", 50}, {"Later", 101}}));
    });
    REQUIRE(error);
    CHECK(error->code() == ErrorCode::InvalidConfig);
    CHECK(std::string(error->what()) == "key registry " + path +
                                            ": the seed gives 'LightValue' index 50 but the "
                                            "registry gave it 42 (an index never changes)");
  }
  SECTION("a known index to another name") {
    try {
      registry.applySeed(seedOf({{"Fresh", 100}, {"Other", 42}, {"Later", 101}}));
      FAIL("no exception");
    } catch (const Error& e) {
      CHECK(e.code() == ErrorCode::InvalidConfig);
      CHECK_THAT(e.what(), Contains("index 42") && Contains("'Other'") && Contains("'LightValue'"));
    }
  }
  // Nothing of the seed was applied, in memory or on disk.
  CHECK_FALSE(registry.find("Fresh"));
  CHECK_FALSE(registry.find("Later"));
  CHECK_FALSE(registry.nameOf(100));
  CHECK(registry.find("LightValue") == KeyIndex{42});
  CHECK(registry.entries().size() == 2);
  KeyRegistry again(path);
  CHECK(again.entries() == Entries{{"LightValue", 42}, {"TiltValue", 43}});
}

TEST_CASE("a file that is not a registry database is InvalidConfig at open",
          "[unit][bridge][registry]") {
  TempDir dir;
  SECTION("text") {
    std::string text;
    std::mt19937 random(std::random_device{}());
    for (int i = 0; i < 4096; ++i) text += static_cast<char>('a' + random() % 26);
    const auto path = dir.write("text.db", text);
    CHECK_THAT(openFailure(path), Contains(path));
  }
  SECTION("a YAML seed given as the database") {
    const auto path = dir.write("keys.yaml", "keys:\n  LightValue: 42\n");
    CHECK_THAT(openFailure(path), Contains(path));
  }
  SECTION("a directory") {
    CHECK_THAT(openFailure(dir.path.string()), Contains(dir.path.string()));
  }
  SECTION("a path in a missing directory") {
    const auto path = dir.file("missing/keys.db");
    CHECK_THAT(openFailure(path), Contains(path) && Contains("cannot open"));
  }
}

TEST_CASE("a registry table with a corrupt row is an error at open", "[unit][bridge][registry]") {
  TempDir dir;
  const auto path = dir.file("keys.db");
  {
    KeyRegistry registry(path);
    registry.applySeed(seedOf({{"LightValue", 42}}));
  }
  SECTION("a name with a '.'") {
    runSql(path, "INSERT INTO peis_tiny_keys (name, idx) VALUES ('bad.name', 7)");
    CHECK_THAT(openFailure(path), Contains("corrupt") && Contains("'bad.name'"));
  }
  SECTION("a name starting with '#'") {
    runSql(path, "INSERT INTO peis_tiny_keys (name, idx) VALUES ('#7', 7)");
    CHECK_THAT(openFailure(path), Contains("corrupt") && Contains("'#7'"));
  }
  SECTION("an empty name") {
    runSql(path, "INSERT INTO peis_tiny_keys (name, idx) VALUES ('', 7)");
    CHECK_THAT(openFailure(path), Contains("corrupt"));
  }
}

TEST_CASE("a registry table made without the constraints is checked at open",
          "[unit][bridge][registry]") {
  TempDir dir;
  const auto path = dir.file("keys.db");
  runSql(path, "CREATE TABLE peis_tiny_keys (name TEXT, idx)");
  SECTION("an index out of range") {
    runSql(path, "INSERT INTO peis_tiny_keys VALUES ('Far', 70000)");
    CHECK_THAT(openFailure(path), Contains("corrupt") && Contains("'Far'"));
  }
  SECTION("an index 0") {
    runSql(path, "INSERT INTO peis_tiny_keys VALUES ('Zero', 0)");
    CHECK_THAT(openFailure(path), Contains("corrupt") && Contains("'Zero'"));
  }
  SECTION("an index that is text") {
    runSql(path, "INSERT INTO peis_tiny_keys VALUES ('Text', 'abc')");
    CHECK_THAT(openFailure(path), Contains("corrupt") && Contains("'Text'"));
  }
  SECTION("no name") {
    runSql(path, "INSERT INTO peis_tiny_keys VALUES (NULL, 5)");
    CHECK_THAT(openFailure(path), Contains("corrupt"));
  }
  SECTION("two names with one index") {
    runSql(path, "INSERT INTO peis_tiny_keys VALUES ('A', 5), ('B', 5)");
    CHECK_THAT(openFailure(path), Contains("corrupt"));
  }
  SECTION("one name with two indexes") {
    runSql(path, "INSERT INTO peis_tiny_keys VALUES ('A', 5), ('A', 6)");
    CHECK_THAT(openFailure(path), Contains("corrupt"));
  }
  SECTION("good rows are read") {
    runSql(path, "INSERT INTO peis_tiny_keys VALUES ('A', 5), ('B', 6)");
    KeyRegistry registry(path);
    CHECK(registry.entries() == Entries{{"A", 5}, {"B", 6}});
  }
}

TEST_CASE("a seed that names one tiny node twice, or two nodes alike, is refused", "[unit]") {
  using peis::bridge::parseRegistrySeed;
  CHECK_THROWS_MATCHES(parseRegistrySeed("nodes:\n  3: plant\n  3: lamp\n", "twice.yaml"),
                       peis::Error,
                       Catch::Matchers::Message("twice.yaml:3: tiny node 3 is given twice"));
  CHECK_THROWS_MATCHES(
      parseRegistrySeed("nodes:\n  3: plant\n  4: plant\n", "alike.yaml"), peis::Error,
      Catch::Matchers::Message("alike.yaml:3: tiny nodes 3 and 4 would both be PEIS 'plant'"));
}
