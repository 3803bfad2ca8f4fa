// Unit tests of the authorization policy (security/policy.h): who a rule
// names, key patterns (a part, `*`, a prefix `x*`, a last `**`), kernel.*
// writes only where named, administrators, revocations, the default
// policy, and clear errors with the line for a broken policy.
#include "security/policy.h"

#include <catch2/catch.hpp>

#include "peis/error.h"

using peis::security::Policy;
using peis::security::Subject;
using Op = Policy::Op;

namespace {

Subject subject(std::string principal, std::vector<std::string> groups = {}, std::string name = "x",
                peis::PeisId id = 5, std::uint64_t serial = 1) {
  return Subject{id, std::move(name), std::move(principal), std::move(groups), serial};
}

}  // namespace

TEST_CASE("policy: rules, patterns and kernel.* writes", "[unit]") {
  const auto policy = Policy::parse(R"(
admin: [principal:root]
rules:
  - who: [group:devices, name:lamp-*]
    read: [light.*, sensors.**, kernel.**]
    write: [light.reqState, mi-*]
  - who: [id:7]
    append: [log.*]
  - who: ['*']
    read: [public.*]
)",
                                    "p.yaml");
  const auto device = subject("d", {"devices"});
  CHECK(policy.allows(device, Op::Read, "light.level"));
  CHECK_FALSE(policy.allows(device, Op::Read, "light.level.x"));
  CHECK(policy.allows(device, Op::Read, "sensors.a.b.c"));
  CHECK_FALSE(policy.allows(device, Op::Read, "sensors"));  // ** is one or more parts
  CHECK(policy.allows(device, Op::Read, "kernel.name"));
  CHECK(policy.allows(device, Op::Write, "light.reqState"));
  CHECK(policy.allows(device, Op::Write, "mi-position"));
  CHECK_FALSE(policy.allows(device, Op::Write, "mi"));
  CHECK_FALSE(policy.allows(device, Op::Append, "light.reqState"));
  CHECK(policy.allows(subject("l", {}, "lamp-2"), Op::Write, "light.reqState"));
  CHECK_FALSE(policy.allows(subject("l", {}, "lamp"), Op::Write, "light.reqState"));
  CHECK(policy.allows(subject("q", {}, "x", 7), Op::Append, "log.events"));
  CHECK(policy.allows(subject("anyone"), Op::Read, "public.news"));
  CHECK_FALSE(policy.allows(subject("anyone"), Op::Read, "light.level"));
  CHECK(policy.isAdmin(subject("root")));
  CHECK_FALSE(policy.isAdmin(device));
}

TEST_CASE("policy: ** never covers a write of kernel.*; the default policy", "[unit]") {
  const auto policy = Policy::parse("rules:\n  - who: ['*']\n    write: ['**']\n", "p");
  CHECK(policy.allows(subject("a"), Op::Write, "anything.at.all"));
  CHECK_FALSE(policy.allows(subject("a"), Op::Write, "kernel.do-quit"));
  const auto defaults = Policy::defaults();
  CHECK(defaults.allows(subject("a"), Op::Write, "light"));
  CHECK(defaults.allows(subject("a"), Op::Read, "kernel.name"));
  CHECK_FALSE(defaults.allows(subject("a"), Op::Write, "kernel.do-quit"));
  CHECK(defaults.allows(subject("a", {"admin"}), Op::Write, "kernel.do-quit"));
  CHECK(defaults.isAdmin(subject("a", {"admin"})));
}

TEST_CASE("policy: revocations by serial and principal", "[unit]") {
  const auto policy = Policy::parse("revoked: [00000000000000ff, principal:mallory]\n", "p.yaml");
  CHECK(policy.revoked(subject("a", {}, "x", 5, 0xff)));
  CHECK(policy.revoked(subject("mallory")));
  CHECK_FALSE(policy.revoked(subject("a", {}, "x", 5, 0xfe)));
}

TEST_CASE("policy: a broken policy names the line and the problem", "[unit]") {
  auto error = [](const std::string& text) {
    try {
      Policy::parse(text, "p.yaml");
    } catch (const peis::Error& e) {
      CHECK(e.code() == peis::ErrorCode::InvalidConfig);
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK(error("rules: [who: [").find("p.yaml:") == 0);
  CHECK(error("rulez: []\n").find("unknown key 'rulez'") != std::string::npos);
  CHECK(error("rules:\n  - who: [nobody]\n").find("p.yaml:2") == 0);
  CHECK(error("rules:\n  - who: ['*']\n    read: [a..b]\n").find("not a key pattern") !=
        std::string::npos);
  CHECK(error("rules:\n  - read: [a]\n").find("has no 'who'") != std::string::npos);
  CHECK(error("revoked: [xyz]\n").find("neither a serial") != std::string::npos);
  CHECK(error("").find("empty policy") != std::string::npos);
}
