// The configurator activating a component that is not running, through the
// launcher (peis-init) of its machine: everything as separate processes over
// loopback. The launcher declares a producer (peis-synthetic as PEIS `pa`,
// off); a consumer runs; a goal that needs the producer makes the
// configurator write `launcher.components.locator.reqState` = `on`, wait for
// `pa` and deploy; withdrawing the goal makes it switch the component off
// again. A component that cannot start, or that never joins, is planned
// around (and one that never joins is switched off again).
#include <catch2/catch.hpp>
#include <filesystem>
#include <string>

#include "ecology.h"
#include "monitor/events.h"
#include "support/temp_dir.h"

using namespace std::chrono_literals;
using Catch::Matchers::Contains;
using peis::PeisId;
using peis::test::MetaEcology;

namespace {

std::string eventsText(MetaEcology& eco) {
  std::vector<std::pair<std::pair<PeisId, std::uint64_t>, std::string>> found;
  for (const auto& t : eco.observer->find(peis::Pattern("config.event.*"))) {
    if (auto n = peis::meta::eventNumber(t.key)) found.push_back({{t.owner, *n}, t.data});
  }
  std::sort(found.begin(), found.end());
  std::string text;
  for (const auto& f : found) text += f.second + "\n";
  return text;
}

// A component file: peis-synthetic with a descriptor of tests/meta/descriptors/.
std::string componentFile(const std::string& name, const std::string& peisName,
                          const std::string& executable, const std::string& descriptor) {
  const auto path = peis::test::descriptorPath(descriptor);
  return "name: " + name + "\nexecutable: " + executable + "\narguments: [--descriptor, \"" + path +
         "\", --period-ms, \"50\", --freshness-ms, \"300\"]\npeis: {name: " + peisName +
         "}\nstart: off\nrestart: {policy: never}\nstop-grace: 5\ndescriptor: \"" + path + "\"\n";
}

}  // namespace

TEST_CASE("the configurator starts a component through its launcher, deploys, and stops it after",
          "[integration]") {
  MetaEcology eco("meta-launch");
  peis::test::TempDir dir("meta-launch");
  dir.write("locator.yaml",
            componentFile("locator", "pa", PEIS_SYNTHETIC_PATH, "position-cheap.yaml"));
  eco.start(PEIS_INIT_PATH, {dir.path.string(), "--peis-name", "launcher"});
  eco.synthetic("c1", "consumer.yaml");
  eco.configurator({"--peis-name", "cfg"});
  const PeisId launcher = eco.await("launcher"), c1 = eco.await("c1"), cfg = eco.await("cfg");
  for (auto id : {c1, cfg}) eco.follow(id, "**");
  eco.follow(launcher, "components.**");
  peis::test::StateReport report([&] { return eventsText(eco) + eco.describeAll(); });
  REQUIRE_WAIT([&] { return eco.value(cfg, "config.configurator") == "active"; }, 30s);
  REQUIRE(eco.value(launcher, "components.locator.currState") == "off");
  REQUIRE(!eco.observer->waitForPeer("pa", 0ms));

  // Planned on the live ecology, the launcher's component is a candidate.
  const auto planned = eco.config({"plan", "position@c1.mi-position"});
  INFO(peis::test::describe(planned));
  CHECK(planned.status == 0);
  CHECK_THAT(planned.out, Contains("c1.mi-position <- pa.position"));

  const auto applied = eco.config({"apply", "position@c1.mi-position", "--timeout", "90"}, 120s);
  INFO(peis::test::describe(applied));
  REQUIRE(applied.status == 0);
  const PeisId pa = eco.await("pa");
  CHECK(eco.value(launcher, "components.locator.reqState") == "on");
  REQUIRE_WAIT(
      [&] {
        return eco.value(launcher, "components.locator.currState") == "on" &&
               eco.value(c1, "mi-position") == std::to_string(pa) + ".position" &&
               eco.value(c1, "status") == "running";
      },
      30s);
  const auto text = eventsText(eco);
  CHECK_THAT(text, Contains("launch asking launcher 'launcher' (" + std::to_string(launcher) +
                            ") to start component locator for PEIS 'pa': "
                            "components.locator.reqState = on"));
  CHECK_THAT(text, Contains("launched PEIS 'pa' (" + std::to_string(pa) + ")"));

  // No goal needs it any more: the configurator asks the launcher to stop it.
  const auto withdrawn = eco.config({"withdraw"});
  INFO(peis::test::describe(withdrawn));
  CHECK(withdrawn.status == 0);
  REQUIRE_WAIT(
      [&] {
        return eco.value(launcher, "components.locator.reqState") == "off" &&
               eco.value(launcher, "components.locator.currState") == "off";
      },
      60s);
  CHECK_THAT(eventsText(eco), Contains("stop no configuration uses PEIS 'pa': asking launcher "
                                       "'launcher' to stop component locator"));
}

namespace {

// A launcher whose component `locator` (PEIS pa, the cheap producer) runs
// `program`, the dear producer pb, the consumer c1 and a configurator with
// `options`; the goal position@c1.mi-position applied. Returns the
// launcher's id once c1 reads pb: the configurator planned around pa.
PeisId plannedAroundLocator(MetaEcology& eco, const peis::test::TempDir& dir,
                            const std::string& program, std::vector<std::string> options) {
  dir.write("locator.yaml", componentFile("locator", "pa", program, "position-cheap.yaml"));
  eco.start(PEIS_INIT_PATH, {dir.path.string(), "--peis-name", "launcher"});
  eco.synthetic("pb", "position-dear.yaml");
  eco.synthetic("c1", "consumer.yaml");
  options.insert(options.begin(), {"--peis-name", "cfg"});
  eco.configurator(options);
  const PeisId launcher = eco.await("launcher"), b = eco.await("pb"), c1 = eco.await("c1"),
               cfg = eco.await("cfg");
  for (auto id : {c1, cfg}) eco.follow(id, "**");
  eco.follow(launcher, "components.**");
  peis::test::StateReport report([&] { return eventsText(eco) + eco.describeAll(); });
  REQUIRE_WAIT([&] { return eco.value(cfg, "config.configurator") == "active"; }, 30s);
  const auto applied = eco.config({"apply", "position@c1.mi-position", "--timeout", "90"}, 120s);
  INFO(peis::test::describe(applied));
  CHECK(applied.status == 0);
  REQUIRE_WAIT(
      [&] {
        return eco.value(c1, "mi-position") == std::to_string(b) + ".position" &&
               eco.value(c1, "status") == "running";
      },
      60s);
  return launcher;
}

}  // namespace

TEST_CASE("a launcher's component that cannot start is named and the configurator plans without it",
          "[fault]") {
  MetaEcology eco("meta-launch-fail");
  peis::test::TempDir dir("meta-launch-fail");
  // The cheap producer's program does not exist; the dear one runs.
  const PeisId launcher = plannedAroundLocator(eco, dir, "no-such-peis-program", {});
  INFO(eventsText(eco));
  CHECK(eco.value(launcher, "components.locator.currState") == "failed");
  CHECK_THAT(eventsText(eco), Contains("launch-failed PEIS 'pa': its launcher says: error: "
                                       "executable 'no-such-peis-program' not found"));
}

TEST_CASE("a launched component that never joins is planned around and switched off again",
          "[fault]") {
  MetaEcology eco("meta-launch-slow");
  peis::test::TempDir dir("meta-launch-slow");
  // The cheap producer's program runs but never joins the ecology.
  const auto script = dir.write("never-joins.sh", "#!/bin/sh\nexec sleep 600\n");
  std::filesystem::permissions(script, std::filesystem::perms::owner_all);
  const PeisId launcher =
      plannedAroundLocator(eco, dir, "./never-joins.sh", {"--launch-wait-ms", "1500"});
  peis::test::StateReport report([&] { return eventsText(eco) + eco.describeAll(); });
  // It was started, and is stopped again since nothing uses it.
  REQUIRE_WAIT(
      [&] {
        return eco.value(launcher, "components.locator.reqState") == "off" &&
               eco.value(launcher, "components.locator.currState") == "off";
      },
      60s);
  const auto text = eventsText(eco);
  CHECK_THAT(text, Contains("launch asking launcher 'launcher'"));
  CHECK_THAT(text, Contains("launch-failed PEIS 'pa': its PEIS did not join within 1500 ms"));
  CHECK_THAT(text, Contains("stop no configuration uses PEIS 'pa'"));
}
