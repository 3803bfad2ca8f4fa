// The scenario runner's pure parts: reading scenario files (file:line
// errors, unknown keys), checking them (unknown programs, PEIS and
// placeholders, faults a PEIS cannot take), the launch plan, conditions and
// their tracker, the clock, the timeline's lines and the SQLite trace.
#include <sqlite3.h>
#include <sys/stat.h>

#include <catch2/catch.hpp>
#include <fstream>

#include "condition.h"
#include "condition_tracker.h"
#include "launch_plan.h"
#include "program_finder.h"
#include "scenario_check.h"
#include "scenario_yaml.h"
#include "sim_clock.h"
#include "support/temp_dir.h"
#include "timeline.h"
#include "trace_writer.h"

using namespace peis::scenario;
using Catch::Matchers::Contains;

namespace {

// A directory of fake programs (executable files) for the checks.
struct FakePrograms {
  peis::test::TempDir dir{"scenario-programs"};
  explicit FakePrograms(std::initializer_list<const char*> names) {
    for (const char* name : names) {
      const auto path = dir.write(name, "#!/bin/sh\nexit 0\n");
      ::chmod(path.c_str(), 0755);
    }
  }
  ProgramFinder finder() const {
    return ProgramFinder("/nonexistent/peis-scenario", dir.path.string(), "");
  }
};

const char* kSmall = R"(name: small
description: two PEIS
speed: 2
deadline: 30
world:
  daylight: 20000
  hosts: [Pippi-base]
peis:
  - name: nav
    program: peis-navigation
    options: [--base, Pippi-base, --log, "{dir}/nav.txt"]
  - name: plant
    id: 3
    tiny: plant
    env: {TINY_SENSOR_FILE: "{dir}/plant.sensors"}
goals:
  - at: 1
    set: nav.ExecGoal
    value: GoTo(bed)
faults:
  - at: 5
    stop: nav
    for: 2
    after: at the bed
timeline:
  - tuple: plant.TiltValue
    say: the plant asks the blind to move ({value})
success:
  - name: at the bed
    tuple: world.physics.scene
    line: robot Pippi
    near: {tuple: world.place.bed, within: 0.15}
    by: 60
  - name: then back
    tuple: nav.ExecStatus
    matches: "^success"
    after: at the bed
)";

std::string errorOf(const std::string& text) {
  try {
    parseScenario(text, "s.yaml");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "no error";
}

std::string joined(const std::vector<std::string>& errors) {
  std::string all;
  for (const auto& e : errors) all += e + "\n";
  return all;
}

}  // namespace

TEST_CASE("scenario: a file is read into the model", "[unit][scenario]") {
  const Scenario s = parseScenario(kSmall, "dir/small.yaml");
  CHECK(s.name == "small");
  CHECK(s.speed == 2);
  REQUIRE(s.world);
  CHECK(s.world->daylight == 20000);
  REQUIRE(s.peis.size() == 2);
  CHECK(s.peis[0].program == "peis-navigation");
  CHECK(s.peis[1].isTiny());
  CHECK(s.peis[1].id == 3);
  CHECK(s.peis[1].origin.str() == "dir/small.yaml:12");
  REQUIRE(s.goals.size() == 1);
  CHECK(s.goals[0].owner == "nav");
  CHECK(s.goals[0].key == "ExecGoal");
  REQUIRE(s.faults.size() == 1);
  CHECK(s.faults[0].describe() == "stop nav at 5 for 2");
  CHECK(s.faults[0].after == "at the bed");
  REQUIRE(s.success.size() == 2);
  CHECK(s.success[0].test.kind == TestKind::Near);
  CHECK(s.success[0].test.nearOwner == "world");
  CHECK(s.success[0].select.line == "robot Pippi");
  CHECK(s.success[1].after == "at the bed");
  CHECK(scenarioDirectory(s) == "dir");
}

TEST_CASE("scenario: broken files are errors naming file:line", "[unit][scenario]") {
  CHECK_THAT(errorOf("name: x\npeis: [\n"), Contains("s.yaml:") && Contains("broken YAML"));
  CHECK_THAT(
      errorOf("name: x\nspeeed: 2\n"),
      Contains("s.yaml:2: unknown key 'speeed' in the scenario (known: ") && Contains("speed"));
  CHECK_THAT(errorOf("description: x\n"), Contains("needs a name"));
  CHECK_THAT(errorOf("name: x\nspeed: fast\n"), Contains("s.yaml:2: speed must be a number"));
  CHECK_THAT(errorOf("name: x\nspeed: 1000\n"), Contains("speed must be in 0.1..100"));
  CHECK_THAT(errorOf("name: x\npeis:\n  - name: a\n"),
             Contains("s.yaml:3: PEIS 'a' needs either program:"));
  CHECK_THAT(errorOf("name: x\npeis:\n  - {name: a, program: p, colour: red}\n"),
             Contains("s.yaml:3: unknown key 'colour' in a PEIS"));
  CHECK_THAT(errorOf("name: x\npeis:\n  - {name: a b, program: p}\n"),
             Contains("may hold only letters"));
  CHECK_THAT(errorOf("name: x\npeis:\n  - {name: a, tiny: plant, on: mars}\n"),
             Contains("on: takes host, avr or auto"));
  CHECK_THAT(errorOf("name: x\nfaults:\n  - {at: 1, stop: a}\n"), Contains("stop needs for:"));
  CHECK_THAT(errorOf("name: x\nfaults:\n  - {at: 1, kill: a, stop: b, for: 1}\n"),
             Contains("exactly one of kill:, stop:, cut:, freeze:"));
  CHECK_THAT(errorOf("name: x\nfaults:\n  - {at: 1, kill: a, for: 3}\n"),
             Contains("kill takes no for:"));
  CHECK_THAT(errorOf("name: x\nsuccess:\n  - {name: c, tuple: a.b, above: 1, below: 2}\n"),
             Contains("has two tests"));
  CHECK_THAT(errorOf("name: x\nsuccess:\n  - {name: c, tuple: a.b}\n"),
             Contains("s.yaml:3: condition 'c' needs a test"));
  CHECK_THAT(errorOf("name: x\nsuccess:\n  - {name: c, tuple: ab, equals: 1}\n"),
             Contains("tuple must be OWNER.KEY, not 'ab'"));
  CHECK_THAT(errorOf("name: x\nsuccess:\n  - {name: c, tuple: a.b, near: {within: 1}}\n"),
             Contains("near needs point: [X, Y] or tuple: OWNER.KEY"));
  CHECK_THAT(errorOf("name: x\ntimeline:\n  - {tuple: a.b, say: hi, when: {bigger: 2}}\n"),
             Contains("unknown key 'bigger' in when"));
  CHECK_THAT(errorOf(""), Contains("s.yaml: the file is empty"));
  CHECK_THROWS_WITH(loadScenario("/nonexistent/x.yaml"),
                    Contains("/nonexistent/x.yaml: cannot open the scenario file"));
}

TEST_CASE("scenario: --inject faults are read and their mistakes named", "[unit][scenario]") {
  const Fault f = parseInjectedFault("stop camera-living-1 at 5 for 8");
  CHECK(f.kind == FaultKind::Stop);
  CHECK(f.peis == "camera-living-1");
  CHECK(f.at == 5);
  CHECK(f.duration == 8);
  CHECK(parseInjectedFault("kill tracker at 30").kind == FaultKind::Kill);
  CHECK_THROWS_WITH(parseInjectedFault("explode tracker at 3"), Contains("KIND one of kill"));
  CHECK_THROWS_WITH(parseInjectedFault("kill tracker at soon"), Contains("KIND PEIS at SECONDS"));
  CHECK_THROWS_WITH(parseInjectedFault("kill tracker at 3 for 2"), Contains("kill takes no for"));
  CHECK_THROWS_WITH(parseInjectedFault("stop tracker at 3"), Contains("stop needs for"));
}

TEST_CASE("scenario: check finds unknown programs and PEIS and placeholders and impossible faults",
          "[unit][scenario]") {
  FakePrograms fake{"peis-sim-world", "peis-navigation", "tiny-plant", "peis-sim-sensors"};
  const ProgramFinder finder = fake.finder();
  SECTION("a valid file") {
    CHECK(joined(checkScenario(parseScenario(kSmall, "small.yaml"), finder)).empty());
  }
  SECTION("a program that does not exist") {
    std::string text = kSmall;
    text.replace(text.find("peis-navigation"), 15, "peis-navigaton");
    CHECK_THAT(joined(checkScenario(parseScenario(text, "small.yaml"), finder)),
               Contains("small.yaml:9: unknown program 'peis-navigaton' (looked in: "));
    // Left out, it is not needed (nor are its faults allowed).
    CHECK_THAT(joined(checkScenario(parseScenario(text, "small.yaml"), finder, {"nav"})),
               !Contains("unknown program") && Contains("hits 'nav', which is left out"));
  }
  SECTION("PEIS the scenario does not have") {
    const std::string text =
        std::string(kSmall) + "  - name: ghost\n    tuple: nobody.status\n    equals: running\n";
    CHECK_THAT(joined(checkScenario(parseScenario(text, "small.yaml"), finder)),
               Contains("small.yaml:38: condition 'ghost' names PEIS 'nobody', which the "
                        "scenario does not have (it has: Pippi-base, nav, plant, world)"));
  }
  SECTION("placeholders, faults, deadlines and after chains") {
    const std::string text = R"(name: bad
peis:
  - {name: a, program: peis-navigation, options: ["{nowhere}"]}
  - {name: s, program: peis-sim-sensors}
  - {name: p, id: 3, tiny: plant, on: host}
  - {name: p2, id: 3, tiny: plant}
faults:
  - {at: 1, cut: a, for: 1}
  - {at: 1, freeze: a}
  - {at: 1, cut: p, for: 1}
  - {at: 1, freeze: s}
  - {at: 1, kill: Pippi-base}
  - {at: 1, kill: a, after: nothing like it}
success:
  - {name: one, tuple: a.x, equals: "1", after: two}
  - {name: two, tuple: a.x, equals: "1", after: one, by: 3}
  - {name: three, tuple: a.x, matches: "([", by: 3}
)";
    const auto errors = joined(checkScenario(parseScenario(text, "bad.yaml"), finder));
    CHECK_THAT(errors, Contains("bad.yaml:3: unknown placeholder {nowhere}"));
    CHECK_THAT(errors, Contains("bad.yaml:6: id 3 is used twice (also by 'p')"));
    CHECK_THAT(errors, Contains("bad.yaml:8: fault 'cut a at 1 for 1': a cut takes a PEIS off the "
                                "simulated radio, and 'a' is not on it"));
    CHECK_THAT(errors, Contains("bad.yaml:9: fault 'freeze a at 1': a freeze holds a simulated "
                                "sensor's readings, and 'a' runs peis-navigation"));
    CHECK_THAT(errors, !Contains("bad.yaml:10:") && !Contains("bad.yaml:11:"));
    CHECK_THAT(errors,
               Contains("bad.yaml:12: fault 'kill Pippi-base at 1' names PEIS 'Pippi-base'"));
    CHECK_THAT(errors, Contains("bad.yaml:13: fault 'kill a at 1' comes after 'nothing like it', "
                                "which is no condition"));
    CHECK_THAT(errors, Contains("bad.yaml:15: condition 'one' has no deadline"));
    CHECK_THAT(errors, Contains("its after: chain goes round"));
    CHECK_THAT(errors, Contains("bad.yaml:17: condition 'three': matches '([' is not a regular "
                                "expression"));
  }
  SECTION("faults given with --inject") {
    const Scenario s = parseScenario(kSmall, "small.yaml");
    CHECK_THAT(joined(checkFaults(s, {parseInjectedFault("kill nobody at 1")}, finder)),
               Contains("--inject: fault 'kill nobody at 1' names PEIS 'nobody'"));
    CHECK(checkFaults(s, {parseInjectedFault("kill nav at 1")}, finder).empty());
  }
  SECTION("no success conditions") {
    CHECK_THAT(joined(checkScenario(parseScenario("name: empty\n", "e.yaml"), finder)),
               Contains("e.yaml:1: the scenario has no success conditions"));
  }
}

TEST_CASE("scenario: the launch plan names every process with its flags and its radio",
          "[unit][scenario]") {
  FakePrograms fake{"peis-sim-world", "peis-navigation", "tiny-plant"};
  const Scenario s = parseScenario(kSmall, "dir/small.yaml");
  RunContext context{"/run", "eco", 31000, 4};
  const LaunchPlan plan = planLaunches(s, context, fake.finder());
  REQUIRE(plan.errors.empty());
  REQUIRE(plan.launches.size() == 3);
  const Launch& world = plan.launches[0];
  CHECK(world.role == LaunchRole::World);
  CHECK(world.argv[0] == fake.dir.file("peis-sim-world"));
  CHECK(world.argv == std::vector<std::string>{fake.dir.file("peis-sim-world"), "--speed", "4",
                                               "--picture", "/run/world-at-exit.png", "--peis-name",
                                               "world", "--peis-ecology", "eco"});
  CHECK(world.joinNames == std::vector<std::string>{"world", "Pippi-base"});
  const Launch& nav = plan.launches[1];
  CHECK(nav.argv == std::vector<std::string>{fake.dir.file("peis-navigation"), "--base",
                                             "Pippi-base", "--log", "/run/nav.txt", "--peis-name",
                                             "nav", "--peis-ecology", "eco"});
  const Launch& plant = plan.launches[2];
  CHECK(plant.role == LaunchRole::TinyHost);
  CHECK(plant.argv == std::vector<std::string>{fake.dir.file("tiny-plant"), "--id", "3"});
  CHECK(plant.joinId == 3);
  CHECK(plant.radioControl == "/run/plant.radio-cut");
  const auto has = [&](const std::string& name, const std::string& value) {
    return std::find(plant.env.begin(), plant.env.end(), std::pair{name, value}) != plant.env.end();
  };
  CHECK(has("TINY_MEDIUM_PORT", "31000"));
  CHECK(has("TINY_SENSOR_FILE", "/run/plant.sensors"));
  CHECK(has("TINY_RADIO_CUT_FILE", "/run/plant.radio-cut"));
}

TEST_CASE("scenario: a node on the emulated MCU runs under the emulator with a gateway",
          "[unit][scenario]") {
  FakePrograms fake{"peis-tinybridge", "simavr_uart_socket", "tiny-blind"};
  const std::string avr = fake.dir.file("firmware-avr");
  std::filesystem::create_directories(avr);
  std::ofstream(avr + "/blind.elf") << "elf";
  // The build tree's table points the finder at the firmware directory.
  peis::test::TempDir self("scenario-self");
  std::ofstream(self.file("peis-scenario-programs.txt")) << "firmware avr " << avr << "\n";
  const ProgramFinder finder(self.file("peis-scenario"), fake.dir.path.string(), "");
  const std::string text = R"(name: mcu
radio: {keys: "{here}/keys.yaml"}
peis:
  - {name: blind, id: 4, tiny: blind, on: auto}
success:
  - {name: closed, tuple: blind.BlindPosition, equals: "0", by: 5}
)";
  const LaunchPlan plan =
      planLaunches(parseScenario(text, "s/mcu.yaml"), {"/run", "eco", 31000, 1}, finder);
  REQUIRE(plan.errors.empty());
  REQUIRE(plan.launches.size() == 2);
  CHECK(plan.launches[0].role == LaunchRole::Emulator);
  CHECK(plan.launches[0].argv.back() == avr + "/blind.elf");
  CHECK(std::find(plan.launches[0].argv.begin(), plan.launches[0].argv.end(), "--time-limit") !=
        plan.launches[0].argv.end());
  CHECK(plan.launches[0].joinId == 4);
  CHECK(plan.launches[1].label == "blind-gateway");
  CHECK(plan.launches[1].argv[1] == "--link");
  CHECK(plan.launches[1].argv[2] == "unix:/run/blind.uart");
  CHECK(plan.launches[1].argv[6] == "s/keys.yaml");
  // Without the emulator's tool, auto falls back to the host radio; avr is an error.
  FakePrograms hostOnly{"peis-tinybridge", "tiny-blind"};
  const auto host =
      planLaunches(parseScenario(text, "mcu.yaml"), {"/run", "eco", 31000, 1}, hostOnly.finder());
  REQUIRE(host.launches.size() == 1);
  CHECK(host.launches[0].role == LaunchRole::TinyHost);
  std::string avrText = text;
  avrText.replace(avrText.find("on: auto"), 8, "on: avr");
  CHECK_THAT(joined(planLaunches(parseScenario(avrText, "mcu.yaml"), {"/run", "eco", 31000, 1},
                                 hostOnly.finder())
                        .errors),
             Contains("needs the simavr_uart_socket tool"));
}

TEST_CASE("scenario: conditions select a part of a value and test it", "[unit][scenario]") {
  const std::string scene = "time 12.3\nrobot Pippi 6.55 4.93 0.1\nrobot Emil 1 1 0\n";
  CHECK(selectPart({"robot Pippi", std::nullopt}, scene) == "6.55 4.93 0.1");
  CHECK(selectPart({"robot Pippi", 2}, scene) == "4.93");
  CHECK(selectPart({"robot Astrid", std::nullopt}, scene) == std::nullopt);
  CHECK(selectPart({"", 9}, "a b") == std::nullopt);

  Test near;
  near.kind = TestKind::Near;
  near.number = 0.15;
  near.nearOwner = "world";
  near.nearKey = "place.bed";
  const auto bed = firstTwoNumbers("6.6 4.9 0");
  CHECK(evaluate(near, std::string("6.55 4.93 0.1"), bed).held);
  CHECK_THAT(evaluate(near, std::string("6.55 4.93 0.1"), bed).detail,
             Contains("0.058 m from (6.600, 4.900)"));
  CHECK_FALSE(evaluate(near, std::string("6.0 4.93"), bed).held);
  CHECK_FALSE(evaluate(near, std::string("6.55 4.93"), std::nullopt).held);
  Test above;
  above.kind = TestKind::Above;
  above.number = 90;
  CHECK(evaluate(above, std::string("95.5")).held);
  CHECK(evaluate(above, std::string("41.2")).detail == "41.2 is not above 90");
  CHECK_FALSE(evaluate(above, std::string("dark")).held);
  CHECK_FALSE(evaluate(above, std::nullopt).held);
  Test equals;
  equals.kind = TestKind::Equals;
  equals.text = "0";
  CHECK(evaluate(equals, std::string("0")).held);
  CHECK_FALSE(evaluate(equals, std::string("00")).held);
  Test matches;
  matches.kind = TestKind::Matches;
  matches.text = "^success [0-9]+ Clean";
  CHECK(evaluate(matches, std::string("success 4 Clean(living-room)")).held);
  CHECK_FALSE(evaluate(matches, std::string("failed 4 Clean(living-room) no position")).held);
}

TEST_CASE("scenario: the condition tracker arms after-conditions and finds missed deadlines",
          "[unit][scenario]") {
  const Scenario s = parseScenario(kSmall, "small.yaml");
  ConditionTracker tracker(s.success, s.deadline);
  // Values before the start are kept, not judged.
  CHECK(tracker.value("world", "place.bed", std::string("6.6 4.9 0"), 0).empty());
  CHECK(tracker.value("nav", "ExecStatus", std::string("success 3 GoTo(bed)"), 0).empty());
  CHECK(tracker.start(0).empty());
  // `then back` waits for `at the bed`, though its own test already holds.
  CHECK_FALSE(tracker.states()[1].held);
  const auto held =
      tracker.value("world", "physics.scene", std::string("robot Pippi 6.6 4.95 0"), 12);
  REQUIRE(held.size() == 2);
  CHECK(held[0].name == "at the bed");
  CHECK(held[1].name == "then back");
  CHECK(tracker.allHeld());

  ConditionTracker late(s.success, s.deadline);
  late.start(0);
  CHECK(late.overdue(29) == nullptr);
  const Condition* missed = late.overdue(30.5);  // `then back` has the scenario's 30 s
  REQUIRE(missed != nullptr);
  CHECK(missed->name == "then back");
  CHECK(late.deadline(s.success[0]) == 60);
}

TEST_CASE("scenario: the clock follows the world's sim.time and holds when it stops",
          "[unit][scenario]") {
  auto now = std::chrono::steady_clock::time_point{};
  SimClock clock(4, true, [&] { return now; });
  CHECK_FALSE(clock.simulated());
  clock.worldTime(10);
  CHECK(clock.simulated() == 10);
  CHECK_FALSE(clock.now());  // no scenario time before start
  clock.start();
  now += std::chrono::milliseconds(20);  // 0.08 s at speed 4
  CHECK(clock.now().value() == Approx(0.08));
  now += std::chrono::seconds(5);  // the world stopped: the clock runs on 0.1 s at most
  CHECK(clock.now().value() == Approx(0.1));
  clock.worldTime(12);
  CHECK(clock.now().value() == Approx(2));
  clock.worldTime(11);  // a late reading does not move it back
  CHECK(clock.now().value() == Approx(2));
  SimClock wall(2, false, [&] { return now; });
  now += std::chrono::seconds(3);
  CHECK(wall.simulated().value() == Approx(6));
}

TEST_CASE("scenario: timeline lines and values for people", "[unit][scenario]") {
  peis::Tuple t;
  t.data = "robot Pippi 1 2\nrobot Emil 3 4\n";
  CHECK(formatValue(t) == "robot Pippi 1 2 robot Emil 3 4");
  t.data = std::string(100, 'x');
  CHECK(formatValue(t, 10) == "xxxxxxxxxx…");
  t.encoding = peis::Encoding::Binary;
  t.mimetype = "image/png";
  t.data = std::string(1234, '\0');
  CHECK(formatValue(t) == "<1234 bytes image/png>");
  const std::string line =
      formatLine(12.44, "plant", "asks the blind to close", "plant.TiltValue = 0");
  CHECK_THAT(line, Contains("    12.4 s  plant            asks the blind to close"));
  CHECK(line.substr(line.size() - 19) == "plant.TiltValue = 0");
  CHECK(formatLine(std::nullopt, "world", "started", "").rfind("            world", 0) == 0);
}

TEST_CASE("scenario: the trace holds every tuple change and the timeline and the verdicts",
          "[unit][scenario]") {
  peis::test::TempDir dir("trace");
  const std::string path = dir.file("t.sqlite");
  {
    TraceWriter trace(path, 8);
    trace.info("scenario", "small");
    trace.peis(12, "nav", "peis-navigation", 4321);
    peis::Tuple t;
    t.owner = 12;
    t.key = "ExecStatus";
    t.data = "running 3 GoTo(bed)";
    t.seqno = 7;
    trace.tuple(t, false, 1.5);
    t.data = "ok";
    trace.tuple(t, false, std::nullopt);
    trace.tuple(t, true, 2.0);
    trace.timeline(1.5, "nav", "drives to the bed", "nav.ExecStatus = running");
    trace.condition("at the bed", true, 12.0, "0.05 m");
    trace.close();
    CHECK(trace.tuplesWritten() == 3);
  }
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(path.c_str(), &db) == SQLITE_OK);
  auto one = [&](const char* sql) {
    sqlite3_stmt* s = nullptr;
    REQUIRE(sqlite3_prepare_v2(db, sql, -1, &s, nullptr) == SQLITE_OK);
    std::string value = sqlite3_step(s) == SQLITE_ROW && sqlite3_column_text(s, 0)
                            ? reinterpret_cast<const char*>(sqlite3_column_text(s, 0))
                            : "<none>";
    sqlite3_finalize(s);
    return value;
  };
  CHECK(one("SELECT value FROM recording WHERE key = 'format'") == "peis-trace 1");
  CHECK(one("SELECT count(*) FROM tuple_events") == "3");
  // Over max_data (8 bytes) the value is left out, its size kept.
  CHECK(one("SELECT coalesce(data, 'NULL') || ' ' || data_size FROM tuple_events WHERE seq = 1") ==
        "NULL 19");
  CHECK(one("SELECT data || ' ' || seqno || ' ' || coalesce(sim_s, 'none') FROM tuple_events WHERE "
            "seq = 2") == "ok 7 none");
  CHECK(one("SELECT event FROM tuple_events WHERE seq = 3") == "delete");
  CHECK(one("SELECT name || ' ' || program || ' ' || pid FROM peis") == "nav peis-navigation 4321");
  CHECK(one("SELECT words FROM timeline") == "drives to the bed");
  CHECK(one("SELECT held || ' ' || detail FROM conditions") == "1 0.05 m");
  sqlite3_close(db);
}

TEST_CASE("scenario: from and changes judge what happens after a time", "[unit][scenario]") {
  const Scenario s = parseScenario(R"(name: repair
success:
  - {name: re-pointed, tuple: vac.mi-position, changes: true, from: 60, by: 120}
  - {name: fresh again, tuple: vac.status, equals: running, after: re-pointed, by: 150}
)",
                                   "r.yaml");
  REQUIRE(s.success[0].test.kind == TestKind::Changes);
  CHECK(s.success[0].from == 60);
  ConditionTracker tracker(s.success, s.deadline);
  tracker.value("vac", "mi-position", std::string("20.position.vac"), 0);
  tracker.value("vac", "status", std::string("running"), 0);
  CHECK(tracker.start(0).empty());
  // A change before `from` does not count, nor does the value at arming.
  CHECK(tracker.value("vac", "mi-position", std::string("20.position.vac"), 30).empty());
  CHECK(tracker.advance(60).empty());
  CHECK(tracker.value("vac", "status", std::string("waiting"), 62).empty());
  const auto held = tracker.value("vac", "mi-position", std::string("21.position.vac"), 64);
  REQUIRE(held.size() == 1);
  CHECK(held[0].name == "re-pointed");
  CHECK_FALSE(tracker.allHeld());  // status says waiting
  const auto fresh = tracker.value("vac", "status", std::string("running"), 65);
  REQUIRE(fresh.size() == 1);
  CHECK(fresh[0].at == 65);
  CHECK(tracker.allHeld());
  CHECK_THAT(
      errorOf("name: x\nsuccess:\n  - {name: c, tuple: a.b, changes: true, from: 9, by: 3}\n"),
      Contains("ends (by) before it starts (from)"));
}
