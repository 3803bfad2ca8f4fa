// The `peis` tool as people use it, run as a real program against PEIS of
// an ecology of its own (in-process Kernels and `peis node` processes):
// settings from the environment, quiet output, did-you-mean answers, watch,
// hz, info, append/erase, values from stdin and files, --ttl, and commands
// that other programs (peis-FOO) provide. Deadlines are generous; nothing
// asserts a timing.
#include <sys/stat.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "peis/component.h"
#include "peis/kernel.h"
#include "support/integration.h"
#include "support/process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using Catch::Matchers::Contains;
using peis::test::cliArgs;
using peis::test::CliResult;
using peis::test::describe;
using peis::test::kDeadline;
using peis::test::kernelOptions;
using peis::test::lines;
using peis::test::listContains;
using peis::test::Process;
using peis::test::randomId;
using peis::test::runCli;
using peis::test::uniqueEcology;
using peis::test::valueOf;
using peis::test::waitFor;

namespace {

// Runs `peis ARGS` exactly as given (no --peis-ecology added) to its end.
CliResult runPeis(std::vector<std::string> args, const Process::Environment& env = {},
                  const std::string& stdinPath = "/dev/null") {
  args.insert(args.begin(), peis::test::peisCliPath());
  Process cli(std::move(args), env, stdinPath);
  const auto status = cli.wait(std::chrono::milliseconds(60s));
  INFO(cli.describe());
  REQUIRE(status.has_value());
  return CliResult{*status, cli.out(), cli.err()};
}

std::string executable(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path) << text;
  ::chmod(path.c_str(), 0755);
  return path;
}

// Waits until `owner` lists PEIS `id` among its subscribers.
void awaitSubscriber(const peis::Kernel& owner, peis::PeisId id, Process& process) {
  const bool subscribed =
      waitFor([&] { return listContains(valueOf(owner, owner.id(), "kernel.subscribers"), id); },
              kDeadline);
  INFO(process.describe());
  REQUIRE(subscribed);
}

}  // namespace

TEST_CASE("peis takes PEIS_ECOLOGY from the environment; a flag wins over it", "[integration]") {
  const auto ecology = uniqueEcology("cli-env");
  peis::Kernel owner(kernelOptions(ecology, "env-owner"));
  owner.set("x", "1");

  auto fromEnv = runPeis({"get", "env-owner.x", "--wait", "15"}, {{"PEIS_ECOLOGY", ecology}});
  INFO(describe(fromEnv));
  CHECK(fromEnv.status == 0);
  CHECK(fromEnv.out == "1\n");

  auto flagWins = runPeis({"get", "env-owner.x", "--wait", "1", "--peis-ecology", ecology + "-b"},
                          {{"PEIS_ECOLOGY", ecology}});
  INFO(describe(flagWins));
  CHECK(flagWins.status == 1);
  CHECK_THAT(flagWins.err, Contains("no PEIS is named 'env-owner'"));

  auto badValue = runPeis({"ls"}, {{"PEIS_ECOLOGY", ecology}, {"PEIS_LIVENESS_MS", "5"}});
  INFO(describe(badValue));
  CHECK(badValue.status == 2);
  CHECK_THAT(badValue.err, Contains("PEIS_LIVENESS_MS: at least 100 ms"));
}

TEST_CASE("a peis command prints its result only, unless --verbose or PEIS_LOG", "[integration]") {
  const auto ecology = uniqueEcology("cli-quiet");
  peis::Kernel owner(kernelOptions(ecology, "quiet-owner"));
  owner.set("greeting", "hi");
  const auto key = std::to_string(owner.id()) + ".greeting";

  auto quiet = runCli(ecology, {"get", key, "--wait", "15"}, 60s);
  INFO(describe(quiet));
  CHECK(quiet.status == 0);
  CHECK(quiet.out == "hi\n");
  CHECK_THAT(quiet.err, !Contains(" info: "));

  auto verbose = runCli(ecology, {"get", key, "--wait", "15", "--verbose"}, 60s);
  INFO(describe(verbose));
  CHECK(verbose.out == "hi\n");
  CHECK_THAT(verbose.err, Contains("info: started as 'peis-get'"));

  auto logged =
      runPeis({"get", key, "--wait", "15", "--peis-ecology", ecology}, {{"PEIS_LOG", "info"}});
  INFO(describe(logged));
  CHECK(logged.out == "hi\n");
  CHECK_THAT(logged.err, Contains("info: started as 'peis-get'"));
}

TEST_CASE("a misspelt key, PEIS name or command gets the closest names", "[integration]") {
  const auto ecology = uniqueEcology("cli-typo");
  auto node =
      peis::test::startNode(ecology, {"--peis-name", "sensor", "--peis-set-tuple", "position=1,2"});
  const auto id = std::to_string(peis::test::awaitNode(*node).id);

  auto key = runCli(ecology, {"get", "sensor.postion", "--wait", "3"}, 60s);
  INFO(describe(key));
  CHECK(key.status == 1);
  CHECK_THAT(key.err, Contains("no key 'postion' at PEIS " + id +
                               " (sensor); did you mean "
                               "'position'?"));

  auto name = runCli(ecology, {"get", "snesor.position", "--wait", "3"}, 60s);
  INFO(describe(name));
  CHECK(name.status == 1);
  CHECK_THAT(name.err, Contains("no PEIS is named 'snesor'; did you mean 'sensor'?"));

  auto erase = runCli(ecology, {"erase", id + ".postion", "--timeout", "15"}, 60s);
  INFO(describe(erase));
  CHECK(erase.status == 1);
  CHECK_THAT(erase.err, Contains("did you mean 'position'?"));
  auto kept = runCli(ecology, {"get", "sensor.position", "--wait", "15"}, 60s);
  INFO(describe(kept));
  CHECK(kept.out == "1,2\n");

  auto command = runPeis({"gte", "sensor.position"});
  INFO(describe(command));
  CHECK(command.status == 2);
  CHECK_THAT(command.err, Contains("'gte' is not a peis command"));
  CHECK_THAT(command.err, Contains("no program peis-gte in PEIS_EXEC_PATH"));
  CHECK_THAT(command.err, Contains("; did you mean 'get'?"));
}

TEST_CASE("peis watch: several patterns, deletions and time stamps", "[integration]") {
  const auto ecology = uniqueEcology("cli-watch");
  peis::Kernel owner(kernelOptions(ecology, "watched"));
  owner.set("a", "1");
  owner.set("b", "1");
  owner.set("c", "not watched");
  const auto id = std::to_string(owner.id());
  Process watch(cliArgs(
      ecology, {"watch", id + ".a", "--stamps", id + ".b", "--count", "4", "--timeout", "60"}));
  // Both current values printed: both subscriptions reached the owner.
  const bool subscribed = waitFor([&] { return lines(watch.out()).size() >= 2; }, kDeadline);
  INFO(watch.describe());
  REQUIRE(subscribed);
  owner.set("c", "still not watched");
  owner.set("a", "2");
  owner.erase("b");
  REQUIRE(watch.wait(kDeadline) == 0);

  const std::regex stamped(R"((\d\d:\d\d:\d\d\.\d\d\d) (.*))");
  std::vector<std::string> events;
  for (const auto& line : lines(watch.out())) {
    std::smatch match;
    REQUIRE(std::regex_match(line, match, stamped));
    events.push_back(match[2]);
  }
  REQUIRE(events.size() == 4);
  CHECK(std::set<std::string>(events.begin(), events.begin() + 2) ==
        std::set<std::string>{id + ".a = 1", id + ".b = 1"});
  CHECK(std::set<std::string>(events.begin() + 2, events.end()) ==
        std::set<std::string>{id + ".a = 2", id + ".b deleted"});
}

TEST_CASE("peis hz reports the rate and jitter of a tuple's updates", "[integration]") {
  const auto ecology = uniqueEcology("cli-hz");
  peis::Kernel owner(kernelOptions(ecology, "stream"));
  const auto base = peis::systemNow();
  auto stamped = [&](int i) {
    peis::WriteOptions options;
    options.ts_user = base + std::chrono::milliseconds(100 * i);
    owner.set("x", std::to_string(i), options);
  };
  stamped(0);
  const auto hzId = randomId();
  const auto id = std::to_string(owner.id());
  Process hz(cliArgs(ecology, {"hz", id + ".x", "--clock", "user", "--interval", "0.3", "--count",
                               "1", "--timeout", "60", "--peis-id", std::to_string(hzId)}));
  awaitSubscriber(owner, hzId, hz);
  const auto coalescedBefore = owner.networkStats().coalesced;
  for (int i = 1; i <= 5; ++i) stamped(i);  // ts_user 100 ms apart: 10 Hz, no jitter
  REQUIRE(hz.wait(kDeadline) == 0);
  INFO(hz.describe());
  const auto report = lines(hz.out());
  REQUIRE(report.size() == 1);
  if (owner.networkStats().coalesced == coalescedBefore) {
    // Every update was sent: the intervals are exactly the stamps'.
    CHECK(std::regex_match(report[0], std::regex(id + R"(\.x: 10\.000 Hz  min 0\.1000s  )"
                                                      R"(max 0\.1000s  std dev 0\.00000s  )"
                                                      R"(window [1-5])")));
  } else {
    // The outbox merged some updates: intervals are whole multiples of 0.1 s.
    CHECK(std::regex_match(report[0], std::regex(id + R"(\.x: \d+\.\d+ Hz  min 0\.[1-5]000s  )"
                                                      R"(max 0\.[1-5]000s  .*)")));
  }
}

TEST_CASE("peis info: a component's status, inputs, outputs, actuators, subscribers",
          "[integration]") {
  const auto ecology = uniqueEcology("cli-info");
  peis::Kernel sensorKernel(kernelOptions(ecology, "sensor"));
  sensorKernel.set("brightness", "40");
  peis::Kernel lampKernel(kernelOptions(ecology, "lamp"));
  peis::Component lamp(lampKernel, "lamp");
  lamp.input("brightness");
  lamp.input("position");
  lamp.output("level");
  lamp.actuator(
      "light", [](const std::string& wanted) { return wanted; }, "off");
  lamp.start();
  lampKernel.setMeta("mi-brightness", sensorKernel.id(), "brightness");
  REQUIRE(waitFor([&] { return lamp.inputFresh("brightness"); }, kDeadline));
  const auto sensorId = std::to_string(sensorKernel.id());
  const auto lampId = std::to_string(lampKernel.id());

  auto info = runCli(ecology, {"info", "lamp", "--wait", "15"}, 60s);
  INFO(describe(info));
  CHECK(info.status == 0);
  CHECK_THAT(info.out, Contains("PEIS " + lampId + " 'lamp'"));
  CHECK_THAT(info.out, Contains(sensorId + " (sensor)"));
  CHECK_THAT(info.out, Contains("component lamp: waiting (position)"));
  CHECK_THAT(info.out, Contains("brightness <- " + sensorId + ".brightness (sensor)\n"));
  CHECK_THAT(info.out, Contains("position <- (nowhere)  [missing or stale]"));
  CHECK_THAT(info.out, Contains("outputs level"));
  CHECK_THAT(info.out, Contains("light: reqState -, currState off, status ok"));

  auto sensor = runCli(ecology, {"info", sensorId, "--wait", "15", "--json"}, 60s);
  INFO(describe(sensor));
  CHECK(sensor.status == 0);
  CHECK_THAT(sensor.out, Contains("\"subscribers\":[" + lampId + "]"));
  CHECK_THAT(sensor.out, Contains("\"component\":\"\""));
}

TEST_CASE("peis set, append and erase; values from stdin and files; --ttl", "[integration]") {
  const auto ecology = uniqueEcology("cli-write");
  peis::Kernel owner(kernelOptions(ecology, "store"));
  const auto id = std::to_string(owner.id());
  peis::test::TempDir dir("peis-cli-write");

  SECTION("append twice, a stale --if-seqno, erase twice") {
    for (const char* part : {"a", "b"}) {
      auto append = runCli(ecology, {"append", id + ".log", part, "--timeout", "15"}, 60s);
      INFO(describe(append));
      REQUIRE(append.status == 0);
    }
    CHECK(valueOf(owner, owner.id(), "log") == "ab");
    auto stale = runCli(ecology, {"append", id + ".log", "c", "--if-seqno", "1"}, 60s);
    INFO(describe(stale));
    CHECK(stale.status == 1);
    CHECK_THAT(stale.err, Contains("seqno"));
    CHECK(valueOf(owner, owner.id(), "log") == "ab");

    auto erase = runCli(ecology, {"erase", id + ".log", "--timeout", "15"}, 60s);
    INFO(describe(erase));
    CHECK(erase.status == 0);
    CHECK_FALSE(owner.get("log").has_value());
    auto again = runCli(ecology, {"erase", id + ".log", "--timeout", "15"}, 60s);
    INFO(describe(again));
    CHECK(again.status == 1);
    CHECK_THAT(again.err, Contains("no key 'log' at PEIS " + id));
  }

  SECTION("a value from stdin, from a file (binary), as written, after --") {
    const auto input = dir.write("stdin.txt", "on\n");
    auto fromStdin = runPeis(
        {"set", id + ".light", "-", "--timeout", "15", "--peis-ecology", ecology}, {}, input);
    INFO(describe(fromStdin));
    CHECK(fromStdin.status == 0);
    CHECK(valueOf(owner, owner.id(), "light") == "on");

    const std::string bytes("\x89PNG\r\n\x1a\n\0\x01\x02", 11);
    const auto image = dir.write("image.png", bytes);
    auto fromFile = runCli(
        ecology, {"--timeout", "15", "set", id + ".image", "@" + image, "--mimetype", "image/png"},
        60s);
    INFO(describe(fromFile));
    CHECK(fromFile.status == 0);
    auto stored = owner.get("image");
    REQUIRE(stored.has_value());
    CHECK(stored->data == bytes);
    CHECK(stored->encoding == peis::Encoding::Binary);
    CHECK(stored->mimetype == "image/png");

    auto literal =
        runCli(ecology, {"set", id + ".at", "@nofile", "--literal", "--timeout", "15"}, 60s);
    INFO(describe(literal));
    CHECK(valueOf(owner, owner.id(), "at") == "@nofile");
    // After "--" everything is an argument, --peis-* flags too: they go first.
    auto dashes = runPeis(
        {"--peis-ecology", ecology, "set", "--timeout", "15", id + ".dash", "--", "--dash"});
    INFO(describe(dashes));
    CHECK(valueOf(owner, owner.id(), "dash") == "--dash");

    auto missing = runCli(ecology, {"set", id + ".x", "@" + dir.file("absent")}, 60s);
    INFO(describe(missing));
    CHECK(missing.status == 2);
    CHECK_THAT(missing.err, Contains("cannot read " + dir.file("absent")));
  }

  SECTION("--ttl: the owner deletes the value when it expires") {
    std::atomic<bool> deleted{false};
    owner.onDelete(peis::Pattern::exact(owner.id(), "short"),
                   [&](const peis::Tuple&) { deleted = true; });
    auto set = runCli(ecology, {"set", id + ".short", "v", "--ttl", "0.5", "--timeout", "15"}, 60s);
    INFO(describe(set));
    REQUIRE(set.status == 0);
    REQUIRE(waitFor([&] { return deleted.load(); }, kDeadline));
    CHECK_THAT(valueOf(owner, owner.id(), "kernel.all-keys"), !Contains("short"));
  }
}

TEST_CASE("peis FOO runs a peis-FOO program found beside peis, in libexec or on PATH",
          "[integration]") {
  peis::test::TempDir dir("peis-cli-sub");
  const auto onPath = dir.file("path");
  executable(onPath + "/peis-hello", "#!/bin/sh\necho \"hello $*\"\n");
  const std::string systemPath = "/usr/bin:/bin";
  const Process::Environment env{{"PATH", onPath + ":" + systemPath}, {"PEIS_EXEC_PATH", ""}};

  auto hello = runPeis({"--peis-ecology", "x", "hello", "a", "--json", "b"}, env);
  INFO(describe(hello));
  CHECK(hello.status == 0);
  CHECK(hello.out == "hello --peis-ecology x a --json b\n");

  auto help = runPeis({"--help"}, env);
  INFO(describe(help));
  CHECK(help.status == 0);
  CHECK_THAT(help.out, Contains("Commands of other programs") && Contains(" hello"));

  auto typo = runPeis({"helo"}, env);
  INFO(describe(typo));
  CHECK(typo.status == 2);
  CHECK_THAT(typo.err, Contains("did you mean 'hello'?"));

  // An installed tree: bin/peis, bin/peis-beside, libexec/peis/peis-inlib.
  const auto bin = dir.file("prefix/bin");
  std::filesystem::create_directories(bin);
  std::filesystem::copy_file(peis::test::peisCliPath(), bin + "/peis");
  executable(bin + "/peis-beside", "#!/bin/sh\necho beside\n");
  executable(dir.file("prefix/libexec/peis/peis-inlib"), "#!/bin/sh\necho inlib \"$1\"\n");
  const Process::Environment bare{{"PATH", systemPath}, {"PEIS_EXEC_PATH", ""}};
  for (const auto& [command, expected] : std::vector<std::pair<std::string, std::string>>{
           {"beside", "beside\n"}, {"inlib", "inlib arg\n"}}) {
    Process installed({bin + "/peis", command, "arg"}, bare);
    const auto status = installed.wait(std::chrono::milliseconds(30s));
    INFO(installed.describe());
    CHECK(status == 0);
    CHECK(installed.out() == expected);
  }
  // PEIS_EXEC_PATH comes first.
  executable(dir.file("override/peis-beside"), "#!/bin/sh\necho override\n");
  Process overridden({bin + "/peis", "beside"},
                     {{"PATH", systemPath}, {"PEIS_EXEC_PATH", dir.file("override")}});
  REQUIRE(overridden.wait(std::chrono::milliseconds(30s)) == 0);
  CHECK(overridden.out() == "override\n");
}

// PeerInfo::tool travels in the Hello and the route adverts
// (docs/protocol.md), so every peer knows a `peis` command's PEIS as a tool.
TEST_CASE("peis ls leaves the short-lived tool PEIS out unless --all", "[integration]") {
  const auto ecology = uniqueEcology("cli-ls-tools");
  auto node = peis::test::startNode(ecology, {"--peis-name", "plain-node"});
  const auto nodeInfo = peis::test::awaitNode(*node);
  const auto watcherId = randomId();
  Process watcher(cliArgs(ecology, {"watch", std::to_string(nodeInfo.id) + ".kernel.name",
                                    "--timeout", "120", "--peis-id", std::to_string(watcherId)}));
  REQUIRE(waitFor([&] { return !watcher.out().empty(); }, kDeadline));

  auto ls = runCli(ecology, {"ls", "--json", "--wait", "15"}, 60s);
  INFO(describe(ls));
  CHECK_THAT(ls.out, Contains("\"name\":\"plain-node\""));
  CHECK_THAT(ls.out, !Contains("\"id\":" + std::to_string(watcherId) + ","));
  auto all = runCli(ecology, {"ls", "--all", "--json", "--wait", "15"}, 60s);
  INFO(describe(all));
  CHECK_THAT(all.out, Contains("\"id\":" + std::to_string(watcherId) + ","));
  CHECK_THAT(all.out, Contains("\"tool\":true"));
}
