// Unit tests of the tinybridge's key mapping: tiny keys (sub-key indexes)
// <-> full keys through the key registry (bridge/src/key_mapping.h).
#include "key_mapping.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <initializer_list>
#include <random>
#include <string>
#include <vector>

#include "peis/error.h"
#include "support/temp_dir.h"

using Catch::Matchers::Contains;
using peis::bridge::fullKeyOf;
using peis::bridge::fullKeyPatternOf;
using peis::bridge::KeyIndex;
using peis::bridge::KeyRegistry;
using peis::bridge::RegistrySeed;
using peis::bridge::tinyKeyOf;
using peis::test::TempDir;

namespace {

// The seed of tiny-peis-kernel.txt section V.
void seedLightAndTilt(KeyRegistry& registry) {
  RegistrySeed seed;
  seed.keys = {{"LightValue", 42}, {"TiltValue", 43}};
  registry.applySeed(seed);
}

tiny_key tinyKey(std::initializer_list<std::uint16_t> parts) {
  tiny_key key{};
  for (auto part : parts) key.sub[key.len++] = part;
  return key;
}

std::vector<std::uint16_t> partsOf(const tiny_key& key) {
  return std::vector<std::uint16_t>(key.sub, key.sub + key.len);
}

using Parts = std::vector<std::uint16_t>;

// tinyKeyOf(fullKey) must fail; returns why.
std::string mappingFailure(KeyRegistry& registry, const std::string& fullKey, bool intern) {
  std::string why;
  const auto key = tinyKeyOf(registry, fullKey, intern, &why);
  if (key) FAIL("'" << fullKey << "' mapped to a tiny key of " << int(key->len) << " parts");
  CHECK_FALSE(why.empty());
  return why;
}

}  // namespace

TEST_CASE("fullKeyOf names each sub-key by the registry", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  CHECK(fullKeyOf(registry, tinyKey({42})) == "LightValue");
  CHECK(fullKeyOf(registry, tinyKey({42, 43})) == "LightValue.TiltValue");
  CHECK(fullKeyOf(registry, tinyKey({43, 42, 43})) == "TiltValue.LightValue.TiltValue");
}

TEST_CASE("fullKeyOf writes an index without a name as #N", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  CHECK(fullKeyOf(registry, tinyKey({999})) == "#999");
  CHECK(fullKeyOf(registry, tinyKey({42, 999})) == "LightValue.#999");
  CHECK(fullKeyOf(registry, tinyKey({65535})) == "#65535");
  CHECK(fullKeyOf(registry, tinyKey({0})) == "#0");
}

TEST_CASE("fullKeyOf never reads past the seven sub-keys", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  tiny_key key{};
  for (auto& part : key.sub) part = 42;
  key.len = 200;  // as a broken frame might claim
  CHECK(fullKeyOf(registry, key) ==
        "LightValue.LightValue.LightValue.LightValue.LightValue.LightValue.LightValue");
  key.len = 0;
  CHECK(fullKeyOf(registry, key) == "");
}

TEST_CASE("tinyKeyOf maps known names and raw #N parts", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  std::string why;
  SECTION("one known part") {
    const auto key = tinyKeyOf(registry, "LightValue", false, &why);
    REQUIRE(key);
    CHECK(partsOf(*key) == Parts{42});
  }
  SECTION("two known parts") {
    const auto key = tinyKeyOf(registry, "LightValue.TiltValue", false, &why);
    REQUIRE(key);
    CHECK(partsOf(*key) == Parts{42, 43});
  }
  SECTION("a raw index without a name") {
    const auto key = tinyKeyOf(registry, "#999", false, &why);
    REQUIRE(key);
    CHECK(partsOf(*key) == Parts{999});
    CHECK_FALSE(registry.nameOf(999));  // nothing was interned
  }
  SECTION("a raw index of a named key is that key") {
    const auto key = tinyKeyOf(registry, "#42.TiltValue", false, &why);
    REQUIRE(key);
    CHECK(partsOf(*key) == Parts{42, 43});
  }
  SECTION("the bounds of raw indexes") {
    CHECK(partsOf(*tinyKeyOf(registry, "#1", false, &why)) == Parts{1});
    CHECK(partsOf(*tinyKeyOf(registry, "#65535", false, &why)) == Parts{65535});
  }
  SECTION("seven parts") {
    const auto key = tinyKeyOf(registry, "#1.#2.#3.#4.#5.#6.LightValue", false, &why);
    REQUIRE(key);
    CHECK(partsOf(*key) == Parts{1, 2, 3, 4, 5, 6, 42});
  }
  SECTION("a null why is fine") {
    CHECK(tinyKeyOf(registry, "LightValue", false, nullptr));
    CHECK_FALSE(tinyKeyOf(registry, "#0", false, nullptr));
  }
}

TEST_CASE("tinyKeyOf and fullKeyOf are inverses", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  for (const std::string full :
       {"LightValue", "LightValue.TiltValue", "#999", "TiltValue.#7.#65535"}) {
    INFO(full);
    const auto key = tinyKeyOf(registry, full, false, nullptr);
    REQUIRE(key);
    CHECK(fullKeyOf(registry, *key) == full);
  }
}

TEST_CASE("tinyKeyOf refuses a bad raw index with a reason", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  for (const std::string bad : {"#0", "#65536", "#01", "#x", "#", "#-1", "#4x", "#1000000"}) {
    INFO("part " << bad);
    CHECK_THAT(mappingFailure(registry, "LightValue." + bad, false),
               Contains("'" + bad + "'") && Contains("raw index"));
    // With intern too: '#' parts are never names.
    CHECK_THAT(mappingFailure(registry, bad, true), Contains("'" + bad + "'"));
  }
  CHECK(registry.entries().size() == 2);
}

TEST_CASE("tinyKeyOf refuses more than seven parts", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  CHECK_THAT(mappingFailure(registry, "#1.#2.#3.#4.#5.#6.#7.#8", false),
             Contains("1..7 parts") && Contains("has 8"));
  CHECK_THAT(mappingFailure(registry, "A.B.C.D.E.F.G.H", true), Contains("has 8"));
  CHECK(registry.entries().size() == 2);  // nothing interned on the way
}

TEST_CASE("tinyKeyOf without intern refuses a name the registry lacks", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  CHECK_THAT(mappingFailure(registry, "LightValue.Unknown", false),
             Contains("'Unknown'") && Contains("no tiny key index"));
  CHECK_FALSE(registry.find("Unknown"));
  CHECK(registry.entries().size() == 2);
}

TEST_CASE("tinyKeyOf with intern gives an unknown part a new, persisted index",
          "[unit][bridge][mapping]") {
  TempDir dir;
  const auto path = dir.file("keys.db");
  {
    KeyRegistry registry(path);
    seedLightAndTilt(registry);
    std::string why;
    const auto key = tinyKeyOf(registry, "LightValue.Fresh", true, &why);
    INFO(why);
    REQUIRE(key);
    CHECK(partsOf(*key) == Parts{42, 44});
    CHECK(registry.find("Fresh") == KeyIndex{44});
    // The same key again, with or without intern: the same tiny key.
    CHECK(partsOf(*tinyKeyOf(registry, "LightValue.Fresh", true, &why)) == Parts{42, 44});
    CHECK(partsOf(*tinyKeyOf(registry, "Fresh.Fresh", false, &why)) == Parts{44, 44});
  }
  KeyRegistry again(path);
  CHECK(again.find("Fresh") == KeyIndex{44});
  const auto key = tinyKeyOf(again, "Fresh", false, nullptr);
  REQUIRE(key);
  CHECK(partsOf(*key) == Parts{44});
  CHECK(fullKeyOf(again, tinyKey({42, 44})) == "LightValue.Fresh");
}

TEST_CASE("a tinyKeyOf that fails interns nothing", "[unit][bridge][mapping]") {
  TempDir dir;
  const auto path = dir.file("keys.db");
  {
    KeyRegistry registry(path);
    seedLightAndTilt(registry);
    SECTION("a bad raw index after a new name") {
      CHECK_THAT(mappingFailure(registry, "Fresh.#0", true), Contains("'#0'"));
    }
    SECTION("a part that cannot be a name after a new name") {
      CHECK_THAT(mappingFailure(registry, "Fresh.x*", true), Contains("'x*'"));
    }
    SECTION("an empty part after a new name") { mappingFailure(registry, "Fresh..x", true); }
    CHECK_FALSE(registry.find("Fresh"));
    CHECK(registry.entries().size() == 2);
  }
  KeyRegistry again(path);
  CHECK_FALSE(again.find("Fresh"));
}

TEST_CASE("fullKeyPatternOf adds .** for a prefix", "[unit][bridge][mapping]") {
  KeyRegistry registry(":memory:");
  seedLightAndTilt(registry);
  CHECK(fullKeyPatternOf(registry, tinyKey({42}), true) == "LightValue.**");
  CHECK(fullKeyPatternOf(registry, tinyKey({42, 43}), true) == "LightValue.TiltValue.**");
  CHECK(fullKeyPatternOf(registry, tinyKey({999}), true) == "#999.**");
  CHECK(fullKeyPatternOf(registry, tinyKey({}), true) == "**");
  CHECK(fullKeyPatternOf(registry, tinyKey({42}), false) == "LightValue");
  CHECK(fullKeyPatternOf(registry, tinyKey({42, 999}), false) == "LightValue.#999");
}
