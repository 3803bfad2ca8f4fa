// The rules of peis-replay and the recording programs' command lines.
#include "recorder/replay_plan.h"

#include <catch2/catch.hpp>

#include "recorder/program_args.h"

using namespace peis::recorder;
using namespace std::chrono_literals;

TEST_CASE("replayed keys: stand-ins keep them, a prefix moves them", "[unit]") {
  std::string why;
  CHECK(replayKey(12, "light.currState", std::nullopt, &why) == "light.currState");
  CHECK_FALSE(replayKey(12, "kernel.name", std::nullopt, &why));
  CHECK(why == "a stand-in's kernel.* tuples are its own kernel's");
  CHECK(replayKey(12, "kernel.name", std::string("old"), &why) == "old.12.kernel.name");
  CHECK(replayKey(12, "a.b", std::string("run.2"), &why) == "run.2.12.a.b");
  std::string longKey(252, 'k');
  CHECK_FALSE(replayKey(12, longKey, std::string("p"), &why));
  CHECK(why.find("256") != std::string::npos);
  CHECK(prefixProblem("replay.one") == std::nullopt);
  CHECK(prefixProblem("a*"));
  CHECK(prefixProblem("a..b"));
}

TEST_CASE("replayed write options: recorded mimetype, encoding, ts_user, expiry as a ttl",
          "[unit]") {
  peis::Tuple t;
  t.mimetype = "image/png";
  t.encoding = peis::Encoding::Binary;
  t.ts_user = peis::Timestamp(5s);
  t.ts_write = peis::Timestamp(10s);
  auto o = replayOptions(t);
  CHECK(o.mimetype == "image/png");
  CHECK(o.encoding == peis::Encoding::Binary);
  CHECK(o.ts_user == peis::Timestamp(5s));
  CHECK(o.ttl == 0us);
  t.ts_expire = peis::Timestamp(12s);
  CHECK(replayOptions(t).ttl == 2s);
}

TEST_CASE("replay timing: the recorded gap divided by the speed", "[unit]") {
  const peis::Timestamp first(100s);
  CHECK(replayOffset(first, first, 1) == 0us);
  CHECK(replayOffset(first + 3s, first, 1) == 3s);
  CHECK(replayOffset(first + 3s, first, 2) == 1500ms);
  CHECK(replayOffset(first + 3s, first, 0.5) == 6s);
  CHECK(replayOffset(first - 1s, first, 1) == 0us);  // never negative
}

TEST_CASE("the recording programs' command lines", "[unit]") {
  const auto parse = [](std::vector<std::string> words) {
    std::vector<char*> argv;
    for (auto& w : words) argv.push_back(w.data());
    return parseProgramArgs(static_cast<int>(argv.size()), argv.data(), {"--output", "--speed"},
                            {"--loop"}, {{"-o", "--output"}});
  };
  auto a = parse({"prog", "*.**", "-o", "x.db", "--loop", "--speed=2", "--", "--not-an-option"});
  CHECK(a.positional == std::vector<std::string>{"*.**", "--not-an-option"});
  CHECK(a.value("--output") == "x.db");
  CHECK(a.has("--loop"));
  CHECK(a.number("--speed", 1, 0.01, 1000) == 2);
  CHECK(a.number("--missing", 7, 0, 10) == 7);
  CHECK_THROWS_WITH(parse({"prog", "--bogus"}), "unknown option --bogus");
  CHECK_THROWS_WITH(parse({"prog", "--output"}), "--output needs a value");
  CHECK_THROWS_WITH(parse({"prog", "--loop=1"}), "--loop takes no value");
  CHECK_THROWS_WITH(parse({"prog", "--speed", "0"}).number("--speed", 1, 0.01, 1000),
                    "--speed: '0' is not a number in 0.01..1000");
  CHECK(parse({"prog", "-h"}).help);
}
