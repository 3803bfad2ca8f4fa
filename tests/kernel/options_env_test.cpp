// The --peis-* settings an ecology shares, from the environment
// (Options::fromEnvironment; PEIS_ECOLOGY as ROS_DOMAIN_ID): applied, a flag
// wins, a bad value names its variable.
#include <catch2/catch.hpp>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "peis/error.h"
#include "peis/options.h"
#include "support/scoped_env.h"

using Catch::Matchers::Contains;
using peis::Options;
using peis::test::ScopedEnv;
using Strings = std::vector<std::string>;

namespace {

Options parse(Strings args) {
  args.insert(args.begin(), "prog");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int argc = static_cast<int>(args.size());
  return Options::fromArgs(argc, argv.data());
}

std::string failure(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const peis::Error& e) {
    CHECK(e.code() == peis::ErrorCode::InvalidArgument);
    return e.what();
  }
  FAIL("expected a peis::Error");
  return {};
}

}  // namespace

TEST_CASE("the shared settings come from PEIS_* variables", "[unit][options]") {
  ScopedEnv env({{"PEIS_ECOLOGY", "lab"},
                 {"PEIS_CONNECT", "a:1, b:2 [::1]:3"},
                 {"PEIS_DISCOVERY_PORT", "7800"},
                 {"PEIS_LIVENESS_MS", "500"},
                 {"PEIS_MAX_DATA", "1024"}});
  for (const auto& o : {Options::fromEnvironment(), parse({})}) {
    CHECK(o.ecology == "lab");
    CHECK(o.connect == Strings{"a:1", "b:2", "[::1]:3"});
    CHECK(o.discoveryPort == 7800);
    CHECK(o.liveness == std::chrono::milliseconds(500));
    CHECK(o.maxDataBytes == 1024);
  }
}

TEST_CASE("a flag wins over its variable", "[unit][options]") {
  ScopedEnv env(
      {{"PEIS_ECOLOGY", "lab"}, {"PEIS_CONNECT", "a:1,b:2"}, {"PEIS_LIVENESS_MS", "500"}});
  const auto o = parse({"--peis-ecology", "home", "--peis-connect", "c:3", "--peis-connect=d:4",
                        "--peis-liveness-ms=900"});
  CHECK(o.ecology == "home");
  CHECK(o.connect == Strings{"c:3", "d:4"});  // the flags replace the variable's list
  CHECK(o.liveness == std::chrono::milliseconds(900));
}

TEST_CASE("without the variables the defaults hold", "[unit][options]") {
  ScopedEnv env({{"PEIS_ECOLOGY", std::nullopt},
                 {"PEIS_CONNECT", std::nullopt},
                 {"PEIS_DISCOVERY_PORT", std::nullopt},
                 {"PEIS_LIVENESS_MS", std::nullopt},
                 {"PEIS_MAX_DATA", std::nullopt},
                 {"PEIS_NAME", "not-read"},  // what singles out one process is not read
                 {"PEIS_PORT", "9999"},
                 {"PEIS_ID", "5"}});
  const auto o = Options::fromEnvironment();
  CHECK(o.ecology == "default");
  ScopedEnv empty({{"PEIS_ECOLOGY", std::string()}});  // set but empty: as if unset
  CHECK(Options::fromEnvironment().ecology == "default");
  CHECK(o.connect.empty());
  CHECK(o.discoveryPort == 7700);
  CHECK(o.liveness == std::chrono::milliseconds(2000));
  CHECK(o.maxDataBytes == peis::kDefaultMaxDataBytes);
  CHECK(o.name.empty());
  CHECK(o.port == 0);
  CHECK_FALSE(o.id.has_value());
}

TEST_CASE("a bad variable is an error naming it", "[unit][options]") {
  struct Case {
    const char* variable;
    const char* value;
    const char* says;
  };
  for (const auto& c :
       {Case{"PEIS_ECOLOGY", "two words", "printable"}, Case{"PEIS_ECOLOGY", "e\x01", "printable"},
        Case{"PEIS_CONNECT", "nohost", "'nohost' is not HOST:PORT"},
        Case{"PEIS_DISCOVERY_PORT", "0", "port 0"},
        Case{"PEIS_LIVENESS_MS", "fast", "not a number"},
        Case{"PEIS_MAX_DATA", "-1", "not a number"}}) {
    INFO(c.variable << "=" << c.value);
    ScopedEnv env({{c.variable, std::string(c.value)}});
    const auto message = failure([] { Options::fromEnvironment(); });
    CHECK_THAT(message, Contains(std::string(c.variable) + ": ") && Contains(c.says));
    // A flag does not rescue a bad variable: the environment is checked first.
    CHECK_THAT(failure([] { parse({}); }), Contains(c.variable));
  }
}

TEST_CASE("isValueFlag knows which --peis-* flags take a value", "[unit][options]") {
  CHECK(Options::isValueFlag("--peis-ecology"));
  CHECK(Options::isValueFlag("--peis-set-tuple"));
  CHECK_FALSE(Options::isValueFlag("--peis-no-discovery"));
  CHECK_FALSE(Options::isValueFlag("--peis-bogus"));
  CHECK_FALSE(Options::isValueFlag("--wait"));
}

TEST_CASE("the help text names the variables", "[unit][options]") {
  const auto text = Options::helpText();
  for (const char* variable :
       {"PEIS_ECOLOGY", "PEIS_CONNECT", "PEIS_DISCOVERY_PORT", "PEIS_LIVENESS_MS", "PEIS_MAX_DATA",
        "PEIS_DISCOVERY_SCOPE", "PEIS_LOG"}) {
    CHECK_THAT(text, Contains(variable));
  }
}
