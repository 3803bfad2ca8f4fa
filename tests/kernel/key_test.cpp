// Unit tests of the key, name and full-name rules (peis/key.h).
#include "peis/key.h"

#include <catch2/catch.hpp>
#include <string>

#include "peis/error.h"
#include "peis/types.h"

using Catch::Matchers::Contains;
using peis::ErrorCode;

namespace {

// Runs `fn`, which must throw peis::Error, and returns that error's code.
template <typename Fn>
ErrorCode codeOf(Fn&& fn) {
  try {
    fn();
  } catch (const peis::Error& e) {
    return e.code();
  }
  FAIL("expected a peis::Error");
  return ErrorCode::Stopped;  // unreachable
}

// Runs `fn`, which must throw peis::Error, and returns its message.
template <typename Fn>
std::string messageOf(Fn&& fn) {
  try {
    fn();
  } catch (const peis::Error& e) {
    return e.what();
  }
  FAIL("expected a peis::Error");
  return {};
}

// A key of `parts` one-letter parts: "a.a.a...".
std::string keyOfParts(std::size_t parts) {
  std::string key = "a";
  for (std::size_t i = 1; i < parts; ++i) key += ".a";
  return key;
}

}  // namespace

TEST_CASE("valid dotted keys have no problem", "[unit][key]") {
  for (const char* key : {"x", "position", "position.x", "a.b.c.d", "kernel.name", "Cam_1-raw",
                          "a/b.c:d", "~!@#$%^&()_+-[]{}|;'\",<>?/`"}) {
    INFO("key: " << key);
    CHECK_FALSE(peis::keyProblem(key).has_value());
    CHECK_NOTHROW(peis::validateKey(key));
  }
}

TEST_CASE("the empty key is rejected", "[unit][key]") {
  const auto problem = peis::keyProblem("");
  REQUIRE(problem.has_value());
  CHECK_THAT(*problem, Contains("empty"));
  CHECK(codeOf([] { peis::validateKey(""); }) == ErrorCode::InvalidKey);
}

TEST_CASE("keys with an empty part are rejected", "[unit][key]") {
  SECTION("empty middle part") {
    const auto problem = peis::keyProblem("a..b");
    REQUIRE(problem.has_value());
    CHECK_THAT(*problem, Contains("part 2 is empty"));
  }
  SECTION("leading dot") {
    const auto problem = peis::keyProblem(".a");
    REQUIRE(problem.has_value());
    CHECK_THAT(*problem, Contains("part 1 is empty"));
  }
  SECTION("trailing dot") {
    const auto problem = peis::keyProblem("a.b.");
    REQUIRE(problem.has_value());
    CHECK_THAT(*problem, Contains("part 3 is empty"));
  }
  SECTION("a lone dot") { CHECK(peis::keyProblem(".").has_value()); }
  for (const char* key : {"a..b", ".a", "a.", "."}) {
    INFO("key: " << key);
    CHECK(codeOf([&] { peis::validateKey(key); }) == ErrorCode::InvalidKey);
  }
}

TEST_CASE("keys may be up to 256 bytes long", "[unit][key]") {
  const std::string longest(peis::kMaxKeyBytes, 'k');
  REQUIRE(longest.size() == 256);
  CHECK_FALSE(peis::keyProblem(longest).has_value());
  CHECK_NOTHROW(peis::validateKey(longest));

  const std::string tooLong(peis::kMaxKeyBytes + 1, 'k');
  const auto problem = peis::keyProblem(tooLong);
  REQUIRE(problem.has_value());
  CHECK_THAT(*problem, Contains("257 bytes"));
  CHECK(codeOf([&] { peis::validateKey(tooLong); }) == ErrorCode::InvalidKey);
}

TEST_CASE("keys may have at most 32 parts", "[unit][key]") {
  CHECK_FALSE(peis::keyProblem(keyOfParts(32)).has_value());
  const auto problem = peis::keyProblem(keyOfParts(33));
  REQUIRE(problem.has_value());
  CHECK_THAT(*problem, Contains("33 parts"));
  CHECK(codeOf([] { peis::validateKey(keyOfParts(33)); }) == ErrorCode::InvalidKey);
}

TEST_CASE("keys reject space, '*', '=', control bytes, DEL and non-ASCII", "[unit][key]") {
  const std::string bad[] = {
      "a b",    "a.b c", "*",     "a.*",   "a*b",         "a=b",  "x.y=1",
      "a\tb",   "a\nb",  "a\x01", "a\x7f", "caf\xc3\xa9", "\xff", std::string("a\0b", 3),
      "a.\x1f",
  };
  for (const auto& key : bad) {
    INFO("key bytes: " << key.size());
    CHECK(peis::keyProblem(key).has_value());
    CHECK(codeOf([&] { peis::validateKey(key); }) == ErrorCode::InvalidKey);
  }
}

TEST_CASE("key problems name the offending part and character", "[unit][key]") {
  const auto star = peis::keyProblem("a.b*");
  REQUIRE(star.has_value());
  CHECK_THAT(*star, Contains("part 2") && Contains("'*'"));

  const auto eq = peis::keyProblem("a=b");
  REQUIRE(eq.has_value());
  CHECK_THAT(*eq, Contains("'='"));

  // Unprintable bytes are shown as their hex value.
  const auto del = peis::keyProblem("a\x7f");
  REQUIRE(del.has_value());
  CHECK_THAT(*del, Contains("0x7f"));
  const auto space = peis::keyProblem("a b");
  REQUIRE(space.has_value());
  CHECK_THAT(*space, Contains("0x20"));
  const auto nonAscii = peis::keyProblem("\xc3\xa9");
  REQUIRE(nonAscii.has_value());
  CHECK_THAT(*nonAscii, Contains("0xc3"));
}

TEST_CASE("validateKey's message quotes the key and the reason", "[unit][key]") {
  const auto message = messageOf([] { peis::validateKey("a..b"); });
  CHECK_THAT(message, Contains("'a..b'") && Contains("part 2 is empty"));

  // Long keys are cut in the message.
  const std::string tooLong(300, 'k');
  const auto cut = messageOf([&] { peis::validateKey(tooLong); });
  CHECK_THAT(cut, Contains("...'"));
  CHECK(cut.find(tooLong) == std::string::npos);
}

TEST_CASE("key patterns allow '*' parts and a trailing '**'", "[unit][key]") {
  for (const char* pattern :
       {"*", "**", "a.*", "*.b", "a.*.c", "*.*.*", "a.**", "*.**", "position.x"}) {
    INFO("pattern: " << pattern);
    CHECK_FALSE(peis::keyPatternProblem(pattern).has_value());
  }
}

TEST_CASE("key patterns reject '**' before the last part and malformed parts", "[unit][key]") {
  for (const char* pattern : {"**.a", "a.**.b", "**.**"}) {
    INFO("pattern: " << pattern);
    const auto problem = peis::keyPatternProblem(pattern);
    REQUIRE(problem.has_value());
    CHECK_THAT(*problem, Contains("'**'"));
  }
  for (const char* pattern : {"", "a..*", "a.*b", "a.b*", "***", "a.***", "a b.*", "a=1.*"}) {
    INFO("pattern: " << pattern);
    CHECK(peis::keyPatternProblem(pattern).has_value());
  }
  CHECK_FALSE(peis::keyPatternProblem("*." + std::string(254, 'a')).has_value());  // 256 bytes
  CHECK(peis::keyPatternProblem("*." + std::string(255, 'a')).has_value());        // 257 bytes
  CHECK(peis::keyPatternProblem(keyOfParts(33)).has_value());
}

TEST_CASE("splitKey splits on every dot", "[unit][key]") {
  using V = std::vector<std::string_view>;
  CHECK(peis::splitKey("a") == V{"a"});
  CHECK(peis::splitKey("a.bc.d") == V{"a", "bc", "d"});
  CHECK(peis::splitKey("a..b") == V{"a", "", "b"});
  CHECK(peis::splitKey("") == V{""});
  CHECK(peis::splitKey(".") == V{"", ""});
}

TEST_CASE("PEIS names: one key part, not all digits, at most 64 bytes", "[unit][key]") {
  for (const char* name : {"Astrid", "robot-1", "cam_2", "7up", "a", "x1234"}) {
    INFO("name: " << name);
    CHECK_FALSE(peis::nameProblem(name).has_value());
    CHECK_NOTHROW(peis::validateName(name));
  }
  CHECK_FALSE(peis::nameProblem(std::string(peis::kMaxNameBytes, 'n')).has_value());

  SECTION("all digits") {
    for (const char* name : {"0", "7", "123456", "99999999999"}) {
      INFO("name: " << name);
      const auto problem = peis::nameProblem(name);
      REQUIRE(problem.has_value());
      CHECK_THAT(*problem, Contains("digits"));
      CHECK(codeOf([&] { peis::validateName(name); }) == ErrorCode::InvalidName);
    }
  }
  SECTION("a dot") {
    for (const char* name : {"a.b", ".", "a.", ".a"}) {
      INFO("name: " << name);
      const auto problem = peis::nameProblem(name);
      REQUIRE(problem.has_value());
      CHECK_THAT(*problem, Contains("'.'"));
      CHECK(codeOf([&] { peis::validateName(name); }) == ErrorCode::InvalidName);
    }
  }
  SECTION("too long") {
    const std::string name(peis::kMaxNameBytes + 1, 'n');
    const auto problem = peis::nameProblem(name);
    REQUIRE(problem.has_value());
    CHECK_THAT(*problem, Contains("65 bytes"));
    CHECK(codeOf([&] { peis::validateName(name); }) == ErrorCode::InvalidName);
  }
  SECTION("empty or bad characters") {
    for (const std::string name : {"", "bad name", "a*", "a=b", "tab\t", "\xc3\xa9"}) {
      INFO("name: " << name);
      CHECK(peis::nameProblem(name).has_value());
      CHECK(codeOf([&] { peis::validateName(name); }) == ErrorCode::InvalidName);
    }
    const auto space = peis::nameProblem("bad name");
    REQUIRE(space.has_value());
    CHECK_THAT(*space, Contains("the name has the character"));
  }
  SECTION("the message names the name") {
    CHECK_THAT(messageOf([] { peis::validateName("12"); }), Contains("'12'"));
  }
}

TEST_CASE("parsePeisId accepts decimal ids in 1..2^31-1 only", "[unit][key]") {
  CHECK(peis::parsePeisId("1") == std::optional<peis::PeisId>(1));
  CHECK(peis::parsePeisId("42") == std::optional<peis::PeisId>(42));
  CHECK(peis::parsePeisId("2147483647") == std::optional<peis::PeisId>(peis::kMaxPeisId));

  for (const char* text : {"", "0", "-1", "-5", "+5", "2147483648", "4294967297", "99999999999",
                           "12a", "a12", " 1", "1 ", "0x10", "1.5", "abc"}) {
    INFO("text: '" << text << "'");
    CHECK_FALSE(peis::parsePeisId(text).has_value());
  }
}

TEST_CASE("parseFullName splits OWNER.KEY at the first dot", "[unit][key]") {
  SECTION("numeric owner") {
    const auto name = peis::parseFullName("7.position.x");
    CHECK(name.owner == "7");
    CHECK(name.key == "position.x");
    CHECK(name.ownerId() == std::optional<peis::PeisId>(7));
    CHECK(name.str() == "7.position.x");
    CHECK(name == peis::FullName{"7", "position.x"});
  }
  SECTION("named owner") {
    const auto name = peis::parseFullName("Astrid.position");
    CHECK(name.owner == "Astrid");
    CHECK(name.key == "position");
    CHECK_FALSE(name.ownerId().has_value());
    CHECK(name.str() == "Astrid.position");
  }
  SECTION("largest id") {
    const auto name = peis::parseFullName("2147483647.k");
    CHECK(name.ownerId() == std::optional<peis::PeisId>(peis::kMaxPeisId));
  }
}

TEST_CASE("parseFullName rejects malformed full names with the right code", "[unit][key]") {
  SECTION("no key part") {
    for (const char* text : {"7", "Astrid", "", ".x", "7.", "."}) {
      INFO("text: " << text);
      CHECK(codeOf([&] { peis::parseFullName(text); }) == ErrorCode::InvalidKey);
    }
    CHECK_THAT(messageOf([] { peis::parseFullName("7"); }), Contains("OWNER.KEY"));
  }
  SECTION("owner id out of range") {
    for (const char* text : {"0.x", "99999999999.x", "2147483648.x"}) {
      INFO("text: " << text);
      CHECK(codeOf([&] { peis::parseFullName(text); }) == ErrorCode::InvalidName);
    }
    CHECK_THAT(messageOf([] { peis::parseFullName("0.x"); }), Contains("out of range"));
  }
  SECTION("bad owner name") {
    for (const char* text : {"bad name.x", "a*.x", "a=b.x", "\x01.x"}) {
      INFO("text: " << text);
      CHECK(codeOf([&] { peis::parseFullName(text); }) == ErrorCode::InvalidName);
    }
  }
  SECTION("bad key") {
    for (const char* text : {"7.a..b", "7.a b", "Astrid.*", "7.x.", "7.a=b"}) {
      INFO("text: " << text);
      CHECK(codeOf([&] { peis::parseFullName(text); }) == ErrorCode::InvalidKey);
    }
  }
}

TEST_CASE("fullName joins owner id and key", "[unit][key]") {
  CHECK(peis::fullName(7, "position.x") == "7.position.x");
  CHECK(peis::fullName(peis::kMaxPeisId, "k") == "2147483647.k");
  // And parses back.
  const auto parsed = peis::parseFullName(peis::fullName(12, "a.b.c"));
  CHECK(parsed.ownerId() == std::optional<peis::PeisId>(12));
  CHECK(parsed.key == "a.b.c");
}
