// Authorization in a secured ecology (issue 13): the owner enforces its
// policy on every remote write and subscription of its tuples. A denied
// write fails with a clear error and changes nothing, a denied subscription
// receives nothing, kernel.do-quit and kernel.policy are an administrator's,
// the configurator is a principal like any other (it re-points mi-*), the
// policy changes at run time, and a revoked principal is cut off. Denials
// are counted and published as kernel.denied.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <memory>
#include <string>

#include "peis/error.h"
#include "peis/peis.h"
#include "secured_peer.h"
#include "support/error_matchers.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

namespace {

using namespace std::chrono_literals;
using peis::ErrorCode;
using peis::PeisId;
using peis::test::HasCode;
using peis::test::waitFor;

constexpr PeisId kOwner = 9501;

const char* kPolicy = R"(# the owner's policy
admin: [group:admin]
rules:
  - who: [group:readers, group:writers]
    read: [light.*, kernel.**]
  - who: [group:writers]
    write: [light.reqState]
    append: [log.*]
  - who: [principal:configurator]
    read: ['**']
    write: [mi-*]
  - who: [group:admin]
    read: ['**']
    write: ['**', kernel.do-quit, kernel.policy]
    delete: ['**']
)";

struct Ecology {
  Ecology()
      : name("policy-" + std::to_string(getpid()) + "-" + std::to_string(++count)), root(name) {
    root.issue("owner");
    root.issue("reader", {"readers"});
    root.issue("writer", {"writers"});
    root.issue("admin", {"admin"});
    root.issue("configurator", {"meta"});
    root.issue("mallory");
    peis::Options o = options("owner", kOwner);
    o.policy = files.write("policy.yaml", kPolicy);
    owner = std::make_unique<peis::Kernel>(o);
    owner->set("light.reqState", "off");
    owner->set("secret.code", "1234");
  }
  peis::Options options(const std::string& principal, PeisId id) {
    peis::Options o;
    o.id = id;
    o.credentials = root.dir() + "/" + principal + ".cred";
    o.discovery = false;
    if (owner) o.connect.push_back("127.0.0.1:" + std::to_string(owner->port()));
    return o;
  }
  std::unique_ptr<peis::Kernel> join(const std::string& principal, PeisId id) {
    auto k = std::make_unique<peis::Kernel>(options(principal, id));
    REQUIRE(k->waitForPeer(std::to_string(kOwner), 20s));
    REQUIRE(waitFor([&] {
      for (const auto& p : owner->peers()) {
        if (p.id == id) return true;
      }
      return false;
    }));
    return k;
  }
  std::string denied() { return owner->get(peis::special::kDenied)->data; }

  static inline int count = 0;
  std::string name;
  peis::test::TestRoot root;
  peis::test::TempDir files;
  std::unique_ptr<peis::Kernel> owner;
};

}  // namespace

TEST_CASE("policy: a denied write fails with the reason and changes nothing", "[integration]") {
  Ecology e;
  auto reader = e.join("reader", 9502);
  auto writer = e.join("writer", 9503);
  CHECK_THROWS_MATCHES(reader->set(kOwner, "light.reqState", "on"), peis::Error,
                       HasCode(ErrorCode::Refused));
  CHECK_THROWS_WITH(reader->set(kOwner, "light.reqState", "on"),
                    Catch::Contains("principal 'reader'") && Catch::Contains("may not set") &&
                        Catch::Contains("9501.light.reqState"));
  CHECK(e.owner->get("light.reqState")->data == "off");
  writer->set(kOwner, "light.reqState", "on");
  CHECK(e.owner->get("light.reqState")->data == "on");
  CHECK_THROWS_MATCHES(writer->set(kOwner, "light.level", "9"), peis::Error,
                       HasCode(ErrorCode::Refused));
  CHECK_FALSE(e.owner->get("light.level"));
  writer->append(kOwner, "log.events", "+1");
  CHECK_THROWS_WITH(writer->append(kOwner, "light.reqState", "x"), Catch::Contains("append to"));
  CHECK_THROWS_WITH(writer->erase(kOwner, "light.reqState"), Catch::Contains("may not delete"));
  CHECK(e.owner->get("light.reqState")->data == "on");
  CHECK(e.owner->accessStats().policyDenied == 5);
  CHECK(e.denied().find("5 denied (policy 5") == 0);
}

TEST_CASE("policy: a denied subscription receives nothing", "[integration]") {
  Ecology e;
  auto reader = e.join("reader", 9502);
  reader->subscribe(peis::Pattern("**", kOwner));
  e.owner->set("secret.more", "5678");
  e.owner->set("light.level", "7");  // arrives after the secrets would have
  REQUIRE(waitFor([&] {
    auto t = reader->get(kOwner, "light.level");
    return t && t->data == "7";
  }));
  CHECK(reader->get(kOwner, "light.reqState"));
  CHECK_FALSE(reader->get(kOwner, "secret.code"));
  CHECK_FALSE(reader->get(kOwner, "secret.more"));
  // A blocking get of a secret: nothing ever comes.
  CHECK_FALSE(reader->get(kOwner, "secret.code", 300ms));
  CHECK(e.owner->accessStats().policyDenied >= 1);
  CHECK(e.denied().find("may not read") != std::string::npos);
}

TEST_CASE("policy: kernel.do-quit is an administrator's", "[integration]") {
  Ecology e;
  auto writer = e.join("writer", 9503);
  CHECK_THROWS_MATCHES(writer->set(kOwner, "kernel.do-quit", "yes"), peis::Error,
                       HasCode(ErrorCode::Refused));
  CHECK_FALSE(e.owner->quitRequested());
  auto admin = e.join("admin", 9504);
  admin->set(kOwner, "kernel.do-quit", "yes");
  CHECK(waitFor([&] { return e.owner->quitRequested(); }));
}

TEST_CASE("policy: the configurator is a principal that may re-point mi-* only", "[integration]") {
  Ecology e;
  e.owner->declareMeta("mi-position");
  auto configurator = e.join("configurator", 9505);
  configurator->setMeta(kOwner, "mi-position", 9505, "position");
  CHECK(e.owner->resolveMeta(kOwner, "mi-position")->owner == 9505);
  CHECK_THROWS_MATCHES(configurator->set(kOwner, "light.reqState", "on"), peis::Error,
                       HasCode(ErrorCode::Refused));
}

TEST_CASE("policy: changed at run time by its administrator only; revocation cuts off",
          "[integration]") {
  Ecology e;
  auto reader = e.join("reader", 9502);
  auto admin = e.join("admin", 9504);
  auto mallory = e.join("mallory", 9506);
  const std::string opened = std::string(kPolicy) +
                             "  - who: [group:readers]\n"
                             "    write: [light.reqState]\n"
                             "revoked: [principal:mallory]\n";
  // Not by a reader, and not a broken policy.
  CHECK_THROWS_WITH(reader->set(kOwner, "kernel.policy", opened),
                    Catch::Contains("only its administrators"));
  CHECK_THROWS_MATCHES(admin->set(kOwner, "kernel.policy", "rules: [who: ["), peis::Error,
                       HasCode(ErrorCode::InvalidConfig));
  CHECK_THROWS_WITH(admin->set(kOwner, "kernel.policy", "rules:\n  - who: [nobody]\n"),
                    Catch::Contains("kernel.policy:2"));
  CHECK_THROWS(reader->set(kOwner, "light.reqState", "on"));
  admin->set(kOwner, "kernel.policy", opened);
  CHECK(e.owner->get(peis::special::kPolicy)->data == opened);
  reader->set(kOwner, "light.reqState", "on");
  CHECK(e.owner->get("light.reqState")->data == "on");
  // Mallory's link is closed and it is not let in again.
  CHECK(waitFor([&] {
    for (const auto& p : e.owner->peers()) {
      if (p.id == 9506) return false;
    }
    return true;
  }));
  const auto refused = e.owner->networkStats().authRefused;
  CHECK(waitFor([&] { return e.owner->networkStats().authRefused > refused; }));  // it redials
}
