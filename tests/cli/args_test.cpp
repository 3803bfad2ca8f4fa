// The `peis` tool's own options (kernel/tools/args.h): anywhere among the
// arguments, "--" ends them, values checked, per-command acceptance, and
// where the command word is when --peis-* flags come first.
#include "args.h"

#include <catch2/catch.hpp>

using Catch::Matchers::Contains;
using peis::cli::Args;
using peis::cli::UsageError;
using Strings = std::vector<std::string>;

namespace {

struct Argv {
  std::vector<std::string> storage;
  std::vector<char*> argv;
  explicit Argv(Strings args) : storage(std::move(args)) {
    storage.insert(storage.begin(), "peis");
    for (auto& s : storage) argv.push_back(s.data());
    argv.push_back(nullptr);
  }
  int argc() const { return static_cast<int>(storage.size()); }
};

Args parse(Strings args) {
  Argv a(std::move(args));
  return peis::cli::parseArgs(a.argc(), a.argv.data());
}

std::string usageError(Strings args) {
  try {
    parse(std::move(args));
  } catch (const UsageError& e) {
    return e.what();
  }
  FAIL("expected a UsageError");
  return {};
}

int commandIndex(Strings args) {
  Argv a(std::move(args));
  return peis::cli::commandIndex(a.argc(), a.argv.data());
}

}  // namespace

TEST_CASE("options before, between and after the arguments", "[unit][cli]") {
  for (const auto& args :
       {Strings{"--json", "get", "7.x", "--wait", "3"}, Strings{"get", "--wait=3", "7.x", "--json"},
        Strings{"get", "7.x", "--json", "--wait", "3"}}) {
    const auto parsed = parse(args);
    CHECK(parsed.command == "get");
    CHECK(parsed.positional == Strings{"7.x"});
    CHECK(parsed.has("--json"));
    CHECK(parsed.seconds("--wait") == Approx(3.0));
  }
}

TEST_CASE("after -- every word is an argument; '-' and negative numbers are too", "[unit][cli]") {
  auto parsed = parse({"set", "7.x", "--", "--json"});
  CHECK(parsed.positional == Strings{"7.x", "--json"});
  CHECK_FALSE(parsed.has("--json"));
  CHECK(parse({"set", "7.x", "-"}).positional == Strings{"7.x", "-"});
  CHECK(parse({"set", "7.x", "-5"}).positional == Strings{"7.x", "-5"});
  CHECK(parse({"set", "7.x", "-0.5"}).positional == Strings{"7.x", "-0.5"});
  CHECK(parse({"--", "get", "7.x"}).command == "get");
}

TEST_CASE("short forms, repeated options and typed values", "[unit][cli]") {
  auto parsed = parse({"ls", "-a", "-v", "--count", "2", "--count", "5"});
  CHECK(parsed.has("--all"));
  CHECK(parsed.has("--verbose"));
  CHECK(parsed.number("--count") == 5);  // the last one wins
  CHECK(parse({"watch", "--timeout", "0.25"}).seconds("--timeout") == Approx(0.25));
  CHECK(parse({"set", "--mimetype", "image/png"}).text("--mimetype") == "image/png");
  CHECK(parse({"append", "--if-seqno", "0"}).number("--if-seqno") == 0);
}

TEST_CASE("bad options are usage errors that say what is wrong", "[unit][cli]") {
  CHECK_THAT(usageError({"get", "--wiat", "3"}),
             Contains("unknown option --wiat") && Contains("did you mean '--wait'?"));
  CHECK_THAT(usageError({"get", "--wait"}), Contains("--wait needs a value"));
  CHECK_THAT(usageError({"get", "--wait", "soon"}), Contains("--wait needs a number of seconds"));
  CHECK_THAT(usageError({"get", "--wait", "-1"}), Contains("--wait needs"));
  CHECK_THAT(usageError({"get", "--wait", "90000"}), Contains("seconds in 0..86400"));
  CHECK_THAT(usageError({"watch", "--count", "0"}), Contains("at least 1"));
  CHECK_THAT(usageError({"watch", "--count", "2x"}), Contains("a whole number"));
  CHECK_THAT(usageError({"ls", "--json=yes"}), Contains("--json takes no value"));
}

TEST_CASE("a command rejects options it does not take", "[unit][cli]") {
  const auto args = parse({"get", "7.x", "--ttl", "3", "--verbose", "--help"});
  CHECK_NOTHROW(peis::cli::checkOptions(parse({"get", "--verbose", "--help"}), {"--wait"}));
  try {
    peis::cli::checkOptions(args, {"--wait", "--json"});
    FAIL("expected a UsageError");
  } catch (const UsageError& e) {
    CHECK_THAT(e.what(), Contains("get does not take --ttl"));
  }
}

TEST_CASE("the command word is found after options and --peis-* flags", "[unit][cli]") {
  CHECK(commandIndex({"get", "7.x"}) == 1);
  CHECK(commandIndex({"--json", "get"}) == 2);
  CHECK(commandIndex({"--wait", "3", "get"}) == 3);
  CHECK(commandIndex({"--peis-ecology", "lab", "config", "plan"}) == 3);
  CHECK(commandIndex({"--peis-ecology=lab", "config"}) == 2);
  CHECK(commandIndex({"--peis-no-discovery", "config"}) == 2);
  CHECK(commandIndex({"--", "config"}) == 2);
  CHECK(commandIndex({"--json"}) == -1);
  CHECK(commandIndex({}) == -1);
}
