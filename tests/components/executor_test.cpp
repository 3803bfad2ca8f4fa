// The plan executor and the talk output as separate processes: Emil's plan
// for waking Johanna up (javaspace-peis-middleware.txt §5) run on Pippi
// through ExecGoal / ExecStatus, its configuration deployed and withdrawn,
// and a plan that cannot succeed ending `failed` with the cause.
#include <catch2/catch.hpp>
#include <filesystem>

#include "home_support.h"
#include "peis/component.h"
#include "support/temp_dir.h"

using peis::test::Home;
using peis::test::programPath;
using peis::test::waitFor;
using namespace std::chrono_literals;

TEST_CASE("the executor runs GoTo(bed), Talk(wakeup), GoTo(sofa) on Pippi and Johanna wakes up",
          "[integration]") {
  Home home("exec-wake");
  peis::test::TempDir speech("talk");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  home.start(programPath("peis-navigation"), {"--peis-name", "Pippi", "--base", "Pippi-base"});
  home.start(programPath("peis-talk"), {"--peis-name", "Pippi-voice", "--base", "Pippi-base",
                                        "--out-dir", speech.path.string()});
  // The tracker runs without cameras: the link is deployed, Pippi stays on odometry.
  home.start(programPath("peis-tracker"),
             {"--targets", std::string(PEIS_SOURCE_DIR) + "/components/sim/homes/peis-home.yaml"});
  for (const char* name : {"world", "Pippi-base", "Pippi", "Pippi-voice", "tracker"})
    REQUIRE(home.await(name) != 0);
  const peis::PeisId world = home.await("world"), pippi = home.await("Pippi");
  home.observer->subscribe(peis::Pattern("physics.person.Johanna", world));
  home.observer->subscribe(peis::Pattern("mi-position", pippi));
  auto& executor =
      home.start(programPath("peis-executor"),
                 {"--peis-name", "Emil-planner", "--exit", "--action", "Talk=$1-voice:Talk($2)",
                  "--link", "position(pippi)=tracker.position.Pippi", "--plan",
                  "GoTo(Pippi, bed) | position(pippi)@Pippi.mi-position; Talk(Pippi, wakeup); "
                  "GoTo(Pippi, sofa) | position(pippi)@Pippi.mi-position"});
  // While a GoTo runs, Pippi's mi-position points at the tracker.
  CHECK(waitFor(
      [&] {
        const auto meta = home.observer->get(pippi, "mi-position");
        return meta && meta->data.find(".position.Pippi") != std::string::npos;
      },
      60s));
  const auto exit = executor.wait(240s);
  INFO(executor.describe() << home.describeAll());
  REQUIRE(exit == 0);
  CHECK(executor.err().find("plan success") != std::string::npos);
  const auto johanna = home.observer->get(world, "physics.person.Johanna");
  REQUIRE(johanna);
  CHECK(johanna->data == "awake");
  // Withdrawn after the last step.
  CHECK(waitFor([&] {
    const auto meta = home.observer->get(pippi, "mi-position");
    return meta && meta->data.empty();
  }));
  // The speech was written to a WAV file.
  bool wav = false;
  for (const auto& entry : std::filesystem::directory_iterator(speech.path))
    wav = wav || (entry.path().extension() == ".wav" && entry.file_size() > 1000);
  CHECK(wav);
}

TEST_CASE("a plan whose step keeps failing ends failed with the cause", "[integration]") {
  Home home("exec-fail");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  home.start(programPath("peis-navigation"), {"--peis-name", "Pippi", "--base", "Pippi-base"});
  REQUIRE(home.await("Pippi") != 0);
  REQUIRE(home.await("world") != 0);
  auto& executor = home.start(programPath("peis-executor"),
                              {"--exit", "--replans", "1", "--plan", "GoTo(Pippi, attic)"});
  const auto exit = executor.wait(120s);
  INFO(executor.describe());
  REQUIRE(exit == 1);
  CHECK(
      executor.err().find("plan failed: GoTo(Pippi, attic) failed on Pippi: unknown place 'attic' "
                          "(gave up after 1 replans)") != std::string::npos);
}

TEST_CASE("the executor refuses a malformed plan and bad options", "[integration]") {
  Home home("exec-bad");
  auto& bad = home.start(programPath("peis-executor"), {"--plan", "GoTo(bed"});
  CHECK(bad.wait(30s) == 2);
  CHECK(bad.err().find("plan step 'GoTo(bed'") != std::string::npos);
  auto& badLink = home.start(programPath("peis-executor"), {"--link", "position"});
  CHECK(badLink.wait(30s) == 2);
  auto& help = home.start(programPath("peis-executor"), {"--help"});
  CHECK(help.wait(30s) == 0);
  CHECK(help.out().find("Usage: peis-executor") != std::string::npos);
  // The program's own options, and the PEIS flags after them.
  CHECK(help.out().find("--plan") != std::string::npos);
  CHECK(help.out().find("--peis-name") != std::string::npos);
}

TEST_CASE("with goal tuples, the executor posts a step's needs and the configurator deploys them",
          "[integration]") {
  Home home("exec-goals");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  home.start(programPath("peis-navigation"), {"--peis-name", "Pippi", "--base", "Pippi-base"});
  const peis::PeisId pippi = home.await("Pippi");
  REQUIRE(pippi != 0);
  auto& executor =
      home.start(programPath("peis-executor"),
                 {"--peis-name", "planner", "--exit", "--configurator", "goal-tuples", "--plan",
                  "GoTo(Pippi, bedroom-door) | position(pippi)@Pippi.mi-position"});
  const peis::PeisId planner = home.await("planner");
  REQUIRE(planner != 0);
  home.observer->subscribe(peis::Pattern("config.goal.*", planner));
  home.observer->subscribe(peis::Pattern("plan.status", planner));
  // The goal is posted where a configurator finds it…
  // (The executor writes its status after the goal: wait for both.)
  REQUIRE(waitFor(
      [&] {
        const auto goal = home.observer->get(planner, "config.goal.planner");
        return goal && goal->data == "position(pippi)@Pippi.mi-position\n" &&
               home.observer->get(planner, "plan.status");
      },
      60s));
  // …and nothing is dispatched until it is deployed.
  const auto waiting = home.observer->get(planner, "plan.status");
  REQUIRE(waiting);
  CHECK(waiting->data.rfind("running deploying", 0) == 0);
  // The configurator deploys it: the observer offers Pippi's position.
  peis::Component tracker(*home.observer, "tracker",
                          peis::Descriptor::fromFile(std::string(PEIS_SOURCE_DIR) +
                                                     "/tests/meta/descriptors/pippi-tracker.yaml"));
  tracker.output("position.Pippi");
  tracker.start();
  tracker.write("position.Pippi", "5.0 4.0");
  home.start(programPath("peis-configurator"), {"--peis-name", "configurator"});
  home.observer->subscribe(peis::Pattern("mi-position", pippi));
  CHECK(waitFor(
      [&] {
        const auto meta = home.observer->get(pippi, "mi-position");
        return meta && meta->data == std::to_string(home.observer->id()) + ".position.Pippi";
      },
      60s));
  const auto exit = executor.wait(120s);
  INFO(executor.describe() << home.describeAll());
  REQUIRE(exit == 0);
  // Withdrawn after the plan: the goal tuple is empty, and the configurator
  // takes the link away.
  CHECK(waitFor([&] {
    const auto goal = home.observer->get(planner, "config.goal.planner");
    return goal && goal->data.empty();
  }));
  CHECK(waitFor(
      [&] {
        const auto meta = home.observer->get(pippi, "mi-position");
        return meta && meta->data.empty();
      },
      60s));
}

TEST_CASE("a task written to the executor is planned with the task planner and run",
          "[integration]") {
  Home home("exec-task");
  peis::test::TempDir files("task");
  const std::string problem = files.write("wakeup.yaml", R"yaml(problem: wakeup
domain: home
objects: {pippi: robot, bed: place, johanna: person, wakeup: message}
init: ["at(pippi, bed)", "in(johanna, bed)", "asleep(johanna)", "wakes(wakeup)"]
goal: ["awake(johanna)"]
)yaml");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  home.start(programPath("peis-talk"), {"--peis-name", "pippi-voice", "--base", "Pippi-base",
                                        "--out-dir", files.path.string()});
  auto& executor = home.start(
      programPath("peis-executor"),
      {"--peis-name", "emil", "--exit", "--action", "Talk=$1-voice:Talk($2)", "--domain",
       std::string(PEIS_SOURCE_DIR) + "/meta/domains/home.domain.yaml", "--problem", problem});
  const peis::PeisId world = home.await("world"), emil = home.await("emil");
  REQUIRE(home.await("pippi-voice") != 0);
  REQUIRE(emil != 0);
  home.observer->subscribe(peis::Pattern("physics.speech", world));
  home.observer->subscribe(peis::Pattern("task.plan", emil));
  // Malformed tasks are refused at the gate.
  CHECK_THROWS_AS(home.observer->set(emil, "task", "awake(johanna"), peis::Error);
  home.observer->set(emil, "task", "awake(johanna)");
  const auto exit = executor.wait(120s);
  INFO(executor.describe() << home.describeAll());
  REQUIRE(exit == 0);
  CHECK(home.observer->get(emil, "task.plan")->data == "Talk(pippi, wakeup)");
  // Pippi said it (the planner believes her at the bed; in the world she is
  // not, so Johanna sleeps on: the plan's step ran, not the story).
  CHECK(waitFor(
      [&] {
        const auto said = home.observer->get(world, "physics.speech");
        return said && said->data.rfind("Pippi ", 0) == 0 &&
               said->data.find("Johanna") != std::string::npos;
      },
      30s));
}

TEST_CASE("an executor without a domain refuses tasks", "[integration]") {
  Home home("exec-notask");
  home.start(programPath("peis-executor"), {"--peis-name", "plain"});
  const peis::PeisId plain = home.await("plain");
  REQUIRE(plain != 0);
  CHECK_THROWS_WITH(home.observer->set(plain, "task", "awake(johanna)"),
                    Catch::Matchers::Contains("plans no tasks"));
  auto& bad = home.start(programPath("peis-executor"), {"--task", "awake(johanna)"});
  CHECK(bad.wait(30s) == 2);
  CHECK(bad.err().find("--task needs --domain and --problem") != std::string::npos);
}
