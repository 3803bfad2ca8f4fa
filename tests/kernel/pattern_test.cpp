// Unit tests of abstract-tuple matching (peis/pattern.h).
#include "peis/pattern.h"

#include <catch2/catch.hpp>
#include <string>

#include "peis/error.h"
#include "peis/tuple.h"

using Catch::Matchers::Contains;
using peis::ErrorCode;
using peis::Pattern;

namespace {

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

peis::Tuple tuple(peis::PeisId owner, std::string key, std::string data = "v") {
  peis::Tuple t;
  t.owner = owner;
  t.creator = owner;
  t.key = std::move(key);
  t.data = std::move(data);
  return t;
}

}  // namespace

TEST_CASE("a pattern without wildcards matches exactly its key", "[unit][pattern]") {
  const Pattern p("position.x");
  CHECK(p.matchesKey("position.x"));
  CHECK_FALSE(p.matchesKey("position"));
  CHECK_FALSE(p.matchesKey("position.x.y"));
  CHECK_FALSE(p.matchesKey("position.y"));
  CHECK_FALSE(p.matchesKey("x.position"));
  CHECK_FALSE(p.matchesKey("position.xx"));
  CHECK_FALSE(p.matchesKey("aposition.x"));
  CHECK_FALSE(p.matchesKey(""));
  CHECK(p.keyPattern() == "position.x");
}

TEST_CASE("matching is case-sensitive", "[unit][pattern]") {
  CHECK_FALSE(Pattern("Position.x").matchesKey("position.x"));
  CHECK_FALSE(Pattern("position.X").matchesKey("position.x"));
  CHECK_FALSE(Pattern("*.X").matchesKey("position.x"));
  CHECK_FALSE(Pattern("POSITION.**").matchesKey("position.x"));
  CHECK(Pattern("Position.*").matchesKey("Position.x"));
}

TEST_CASE("'*' matches exactly one part", "[unit][pattern]") {
  SECTION("last part") {
    const Pattern p("position.*");
    CHECK(p.matchesKey("position.x"));
    CHECK(p.matchesKey("position.yaw"));
    CHECK_FALSE(p.matchesKey("position"));      // not zero parts
    CHECK_FALSE(p.matchesKey("position.x.y"));  // not two parts
    CHECK_FALSE(p.matchesKey("pose.x"));
    CHECK_FALSE(p.matchesKey("positionx"));
    CHECK_FALSE(p.matchesKey("position."));  // an empty part is no part
  }
  SECTION("first part") {
    const Pattern p("*.x");
    CHECK(p.matchesKey("position.x"));
    CHECK(p.matchesKey("a.x"));
    CHECK_FALSE(p.matchesKey("x"));
    CHECK_FALSE(p.matchesKey("a.b.x"));
    CHECK_FALSE(p.matchesKey("a.y"));
  }
  SECTION("middle part") {
    const Pattern p("a.*.c");
    CHECK(p.matchesKey("a.b.c"));
    CHECK(p.matchesKey("a.zzz.c"));
    CHECK_FALSE(p.matchesKey("a.c"));
    CHECK_FALSE(p.matchesKey("a.b.b.c"));
    CHECK_FALSE(p.matchesKey("a.b.d"));
    CHECK_FALSE(p.matchesKey("a.b.c.d"));
  }
  SECTION("only part") {
    const Pattern p("*");
    CHECK(p.matchesKey("a"));
    CHECK(p.matchesKey("kernel"));
    CHECK_FALSE(p.matchesKey("a.b"));
    CHECK_FALSE(p.matchesKey(""));
  }
  SECTION("several") {
    const Pattern p("*.*");
    CHECK(p.matchesKey("a.b"));
    CHECK_FALSE(p.matchesKey("a"));
    CHECK_FALSE(p.matchesKey("a.b.c"));
  }
}

TEST_CASE("a trailing '**' matches one or more remaining parts", "[unit][pattern]") {
  SECTION("after a literal part") {
    const Pattern p("position.**");
    CHECK(p.matchesKey("position.x"));
    CHECK(p.matchesKey("position.x.y"));
    CHECK(p.matchesKey("position.a.b.c.d"));
    CHECK_FALSE(p.matchesKey("position"));  // not zero parts
    CHECK_FALSE(p.matchesKey("pose.x"));
    CHECK_FALSE(p.matchesKey("positionx.y"));
    CHECK_FALSE(p.matchesKey("positio"));
  }
  SECTION("alone") {
    const Pattern p("**");
    CHECK(p.matchesKey("a"));
    CHECK(p.matchesKey("a.b.c"));
    CHECK_FALSE(p.matchesKey(""));
  }
  SECTION("after '*'") {
    const Pattern p("*.**");
    CHECK(p.matchesKey("a.b"));
    CHECK(p.matchesKey("a.b.c"));
    CHECK_FALSE(p.matchesKey("a"));
  }
  SECTION("after two parts") {
    const Pattern p("a.b.**");
    CHECK(p.matchesKey("a.b.c"));
    CHECK_FALSE(p.matchesKey("a.b"));
    CHECK_FALSE(p.matchesKey("a"));
    CHECK_FALSE(p.matchesKey("a.c.d"));
  }
}

TEST_CASE("invalid key patterns throw InvalidKey", "[unit][pattern]") {
  for (const char* text : {"", "a..b", ".a", "a.", "**.a", "a.**.b", "a b", "a=1", "a*", "***"}) {
    INFO("pattern: " << text);
    CHECK(codeOf([&] { Pattern p(text); }) == ErrorCode::InvalidKey);
  }
  try {
    Pattern p("**.a");
    FAIL("no exception");
  } catch (const peis::Error& e) {
    CHECK_THAT(e.what(), Contains("'**.a'") && Contains("last part"));
  }
}

TEST_CASE("an invalid owner id in the constructor throws InvalidArgument", "[unit][pattern]") {
  CHECK(codeOf([] { Pattern p("a", 0); }) == ErrorCode::InvalidArgument);
  CHECK(codeOf([] { Pattern p("a", -3); }) == ErrorCode::InvalidArgument);
  CHECK_NOTHROW(Pattern("a", peis::kMaxPeisId));
}

TEST_CASE("the owner filter restricts the owner", "[unit][pattern]") {
  const Pattern p("position.*", 7);
  REQUIRE(p.ownerFilter() == std::optional<peis::PeisId>(7));
  CHECK(p.matchesOwnerAndKey(7, "position.x"));
  CHECK_FALSE(p.matchesOwnerAndKey(8, "position.x"));
  CHECK_FALSE(p.matchesOwnerAndKey(7, "position"));
  CHECK(p.matches(tuple(7, "position.x")));
  CHECK_FALSE(p.matches(tuple(8, "position.x")));

  const Pattern any("position.*");
  CHECK_FALSE(any.ownerFilter().has_value());
  CHECK(any.matchesOwnerAndKey(1, "position.x"));
  CHECK(any.matchesOwnerAndKey(99, "position.x"));

  Pattern set("position.*");
  set.owner(3);
  CHECK(set.matchesOwnerAndKey(3, "position.x"));
  CHECK_FALSE(set.matchesOwnerAndKey(4, "position.x"));
}

TEST_CASE("creator, mimetype and data filters must all hold", "[unit][pattern]") {
  auto t = tuple(7, "image", "bytes");
  t.creator = 9;
  t.mimetype = "image/jpeg";

  SECTION("creator") {
    Pattern p("image");
    p.creator(9);
    CHECK(p.matches(t));
    p.creator(7);
    CHECK_FALSE(p.matches(t));
  }
  SECTION("mimetype") {
    Pattern p("image");
    p.mimetype("image/jpeg");
    CHECK(p.matches(t));
    p.mimetype("image/png");
    CHECK_FALSE(p.matches(t));
    p.mimetype("IMAGE/JPEG");
    CHECK_FALSE(p.matches(t));
  }
  SECTION("data") {
    Pattern p("image");
    p.data("bytes");
    CHECK(p.matches(t));
    p.data("byte");
    CHECK_FALSE(p.matches(t));
    p.data("");
    CHECK_FALSE(p.matches(t));
  }
  SECTION("combined, chained") {
    Pattern p("*");
    p.owner(7).creator(9).mimetype("image/jpeg").data("bytes");
    CHECK(p.matches(t));
    auto other = t;
    other.data = "other";
    CHECK_FALSE(p.matches(other));
    other = t;
    other.creator = 1;
    CHECK_FALSE(p.matches(other));
    other = t;
    other.owner = 1;
    CHECK_FALSE(p.matches(other));
    other = t;
    other.key = "image.raw";
    CHECK_FALSE(p.matches(other));
    other = t;
    other.mimetype = peis::kDefaultMimetype;
    CHECK_FALSE(p.matches(other));
  }
  SECTION("no filters ignore those fields") {
    const Pattern p("image");
    auto other = t;
    other.creator = 123;
    other.mimetype = "x/y";
    other.data = "";
    CHECK(p.matches(other));
  }
}

TEST_CASE("Pattern::parse reads OWNER.KEYPATTERN", "[unit][pattern]") {
  SECTION("any owner") {
    const auto p = Pattern::parse("*.position.**");
    CHECK_FALSE(p.ownerFilter().has_value());
    CHECK(p.keyPattern() == "position.**");
    CHECK(p.matchesOwnerAndKey(3, "position.x"));
    CHECK(p.matchesOwnerAndKey(4, "position.x.y"));
    CHECK_FALSE(p.matchesOwnerAndKey(3, "position"));
    CHECK_FALSE(p.isExact());
    CHECK(p.str() == "*.position.**");
  }
  SECTION("one owner, exact key") {
    const auto p = Pattern::parse("7.a.b");
    CHECK(p.ownerFilter() == std::optional<peis::PeisId>(7));
    CHECK(p.keyPattern() == "a.b");
    CHECK(p.matchesOwnerAndKey(7, "a.b"));
    CHECK_FALSE(p.matchesOwnerAndKey(8, "a.b"));
    CHECK_FALSE(p.matchesOwnerAndKey(7, "a.b.c"));
    CHECK(p.isExact());
    CHECK(p.str() == "7.a.b");
  }
  SECTION("wildcard owner and key") {
    const auto p = Pattern::parse("*.**");
    CHECK(p.matchesOwnerAndKey(1, "anything.at.all"));
  }
}

TEST_CASE("Pattern::parse rejects malformed patterns", "[unit][pattern]") {
  SECTION("no dot or a bad key pattern: InvalidKey") {
    for (const char* text : {"", "7", "*", "position", "7.", "*.", "7.a..b", "*.**.a", "7.a b"}) {
      INFO("text: " << text);
      CHECK(codeOf([&] { Pattern::parse(text); }) == ErrorCode::InvalidKey);
    }
  }
  SECTION("an owner that is not an id or '*': InvalidName") {
    for (const char* text : {".a", "Astrid.a", "0.a", "-1.a", "2147483648.a", "**.a", "7x.a"}) {
      INFO("text: " << text);
      CHECK(codeOf([&] { Pattern::parse(text); }) == ErrorCode::InvalidName);
    }
  }
}

TEST_CASE("Pattern() matches everything", "[unit][pattern]") {
  const Pattern p;
  CHECK_FALSE(p.ownerFilter().has_value());
  CHECK(p.matchesKey("a"));
  CHECK(p.matchesKey("a.b.c.d"));
  CHECK(p.matchesOwnerAndKey(1, "x"));
  CHECK(p.matchesOwnerAndKey(peis::kMaxPeisId, "kernel.name"));
  auto t = tuple(5, "k.l");
  t.creator = 77;
  t.mimetype = "application/octet-stream";
  t.encoding = peis::Encoding::Binary;
  CHECK(p.matches(t));
  CHECK_FALSE(p.isExact());
  CHECK(p.str() == "*.**");
}

TEST_CASE("isExact needs an owner, no wildcard and no other filter", "[unit][pattern]") {
  CHECK(Pattern::exact(7, "a.b").isExact());
  CHECK(Pattern("a.b", 7).isExact());
  CHECK_FALSE(Pattern("a.b").isExact());      // no owner
  CHECK_FALSE(Pattern("a.*", 7).isExact());   // wildcard
  CHECK_FALSE(Pattern("a.**", 7).isExact());  // wildcard
  CHECK_FALSE(Pattern("a.b", 7).creator(1).isExact());
  CHECK_FALSE(Pattern("a.b", 7).mimetype("text/plain").isExact());
  CHECK_FALSE(Pattern("a.b", 7).data("x").isExact());
  CHECK(Pattern("a.b").owner(7).isExact());
}

TEST_CASE("Pattern::exact validates the key as a concrete key", "[unit][pattern]") {
  const auto p = Pattern::exact(7, "position.x");
  CHECK(p.matchesOwnerAndKey(7, "position.x"));
  CHECK_FALSE(p.matchesOwnerAndKey(7, "position.y"));
  CHECK(p.str() == "7.position.x");
  CHECK(codeOf([] { Pattern::exact(7, "position.*"); }) == ErrorCode::InvalidKey);
  CHECK(codeOf([] { Pattern::exact(7, "**"); }) == ErrorCode::InvalidKey);
  CHECK(codeOf([] { Pattern::exact(7, "a..b"); }) == ErrorCode::InvalidKey);
}

TEST_CASE("str() writes OWNER.KEYPATTERN and parses back", "[unit][pattern]") {
  CHECK(Pattern("a.*").str() == "*.a.*");
  CHECK(Pattern("a.*", 12).str() == "12.a.*");
  for (const char* text : {"*.a.*", "12.a.**", "5.x", "*.**"}) {
    INFO("text: " << text);
    CHECK(Pattern::parse(text).str() == text);
  }
}
