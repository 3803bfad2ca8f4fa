// Unit tests of the meta-level runtime's pure parts: the live model and its
// conversions, the deployment diff and its records, goal tuples, the
// monitor's decisions, recovery and the anti-flap rule, event texts.
#include <catch2/catch.hpp>

#include "deploy/deployment_diff.h"
#include "introspect/live_model.h"
#include "monitor/events.h"
#include "monitor/goal_tuples.h"
#include "monitor/health.h"
#include "peis/error.h"
#include "peis/meta/planner.h"

using namespace peis::meta;
using Catch::Matchers::Contains;
using namespace std::chrono_literals;

namespace {

peis::Descriptor descriptor(const char* yaml) { return peis::Descriptor::fromYaml(yaml, "test"); }

LivePeis livePeis(int id, const std::string& name, const char* yaml = nullptr) {
  LivePeis p;
  p.id = id;
  p.name = name;
  p.incarnation = 1000 + id;
  if (yaml) {
    p.descriptor = descriptor(yaml);
    p.component = p.descriptor->component;
  }
  p.status = "running";
  return p;
}

const char* kCamera = R"yaml(
component: camera
functionalities:
  - {name: capture, outputs: [{name: image, type: image}], cost: 1})yaml";
const char* kTracker = R"yaml(
component: tracker
functionalities:
  - name: track
    inputs: [{name: image, type: image}]
    outputs: [{name: position, type: "position(?r)"}]
    preconditions: ["sees(?r)"]
    activation: tracking
    cost: 2)yaml";
const char* kRobot = R"yaml(
component: robot
functionalities:
  - name: drive
    inputs: [{name: position, type: "position(?self)", key: mi-position}]
    cost: 1
  - {name: odometry, outputs: [{name: odometry, type: "position(?self)"}], cost: 9})yaml";

// cam (1) -> tracker (2) -> vac (3)
LiveModel home() {
  LiveModel live;
  live.peis.push_back(livePeis(1, "cam", kCamera));
  auto tracker = livePeis(2, "tracker", kTracker);
  tracker.facts = {"sees(vac)"};
  live.peis.push_back(tracker);
  live.peis.push_back(livePeis(3, "vac", kRobot));
  return live;
}

PlanResult planHome(const LiveModel& live, std::vector<InstanceSelector> failed = {}) {
  ConfigurationPlanner planner(live.toModel());
  for (const auto& s : failed) planner.setFailed(s, true);
  return planner.plan(Goals::fromArguments({"position(vac)@vac.mi-position"}));
}

}  // namespace

TEST_CASE("a launcher's components that do not run are in the planner's model, with id 0",
          "[unit][meta-runtime]") {
  auto live = home();
  // vac does not run; a launcher declares it, and a dear camera it does not start.
  live.peis.erase(live.peis.begin() + 2);
  auto launcher = livePeis(7, "launcher");
  LaunchEntry vac;
  vac.peisName = "vac";
  vac.descriptor = descriptor(kRobot);
  vac.reqState = vac.currState = "off";
  vac.status = "ok";
  launcher.launches["robot"] = vac;
  LaunchEntry broken = vac;
  broken.peisName = "cam2";
  broken.descriptor = descriptor(kCamera);
  broken.currState = "failed";
  broken.status = "error: executable 'x' not found (cam2.yaml:2)";
  launcher.launches["camera2"] = broken;
  LaunchEntry cam = broken;  // cam runs already: the launcher's entry adds nothing
  cam.peisName = "cam";
  cam.currState = "off";
  launcher.launches["camera"] = cam;
  live.peis.push_back(launcher);
  auto earlier = livePeis(9, "vac");  // an earlier run of vac: replaced
  earlier.alive = false;
  live.peis.push_back(earlier);

  REQUIRE(live.launchable("vac"));
  CHECK(live.launchable("vac")->launcher->id == 7);
  CHECK(live.launchable("vac")->component == "robot");
  CHECK_FALSE(live.launchable("cam2"));  // failed
  CHECK_FALSE(live.launchable("nobody"));
  const auto model = live.toModel();
  const auto* p = model.findPeis("vac");
  REQUIRE(p);
  CHECK(p->id == 0);
  CHECK(p->alive);
  REQUIRE(p->components.size() == 1);
  CHECK(p->components[0].component == "robot");
  CHECK(model.findPeis("cam2") == nullptr);
  CHECK(model.findPeis("cam")->id == 1);
  const auto result = planHome(live);
  REQUIRE(result.ok());
  bool usesVac = false;
  for (const auto& l : result.configuration.links)
    usesVac |= l.consumerPeis == "vac" && l.consumerId == 0;
  CHECK(usesVac);

  // A gone launcher offers nothing.
  live.peis[live.peis.size() - 2].alive = false;
  CHECK_FALSE(live.launchable("vac"));
  CHECK(live.toModel().findPeis("vac")->id == 9);
  CHECK_FALSE(live.toModel().findPeis("vac")->alive);
  live.peis[live.peis.size() - 2].alive = true;

  // The launches go through model.live's YAML and show in the text.
  CHECK(LiveModel::fromYaml(live.toYaml()) == live);
  CHECK_THAT(live.toText(), Contains("launches robot as 'vac': off") &&
                                Contains("launches camera2 as 'cam2': failed, error: executable"));
  CHECK_THAT(live.toJson(), Contains("\"launches\":{\"camera\":{\"peisName\":\"cam\""));
}

TEST_CASE("the live model becomes the planner's model", "[unit][meta-runtime]") {
  auto live = home();
  auto gone = livePeis(9, "vac");  // vac's earlier life under another id
  gone.alive = false;
  live.peis.push_back(gone);
  auto odd = livePeis(10, "has space");  // not a plain word for the planner
  live.peis.push_back(odd);
  for (int life : {11, 12}) {  // two gone lives of one PEIS: only the last is kept
    auto old = livePeis(life, "old");
    old.alive = false;
    live.peis.push_back(old);
  }
  live.peis[0].radio = true;
  const auto model = live.toModel();
  REQUIRE(model.peis.size() == 5);
  CHECK(model.findPeis("old")->id == 12);
  CHECK_FALSE(model.findPeis("old")->alive);
  CHECK(model.findPeis("vac")->id == 3);
  CHECK(model.findPeis("peis-10") != nullptr);
  CHECK(model.findPeis("cam")->radio);
  REQUIRE(model.facts.size() == 1);
  CHECK(model.facts[0].atom.toString() == "sees(vac)");
  CHECK(model.facts[0].publisher == "tracker");
  const auto result = planHome(live);
  REQUIRE(result.ok());
  CHECK(result.configuration.cost == Approx(1 + 2 + 4 + 1));  // radio link from the camera

  CHECK(factOfKey("fact.in-view.pippi.cam1")->toString() == "in-view(pippi,cam1)");
  CHECK(factOfKey("fact.powered")->toString() == "powered");
  CHECK_FALSE(factOfKey("status"));
  CHECK(live.canonicalTarget("tracker.position.vac") == "2.position.vac");
  CHECK(live.canonicalTarget("2.position.vac") == "2.position.vac");
  CHECK(live.canonicalTarget("nobody.x") == "nobody.x");
}

TEST_CASE("the live model round-trips through YAML and prints for a person",
          "[unit][meta-runtime]") {
  auto live = home();
  live.peis[2].links["mi-position"] = "2.position.vac";
  live.peis[2].status = "waiting";
  live.peis[2].causes = "position";
  live.peis[1].actuators["tracking"] = {"r=vac", "r=vac", "ok"};
  live.peis[1].goals["config.goal.x"] = "position(vac)@vac.mi-position\n";
  live.peis[1].owned = "3 77\ntracking.reqState\n";
  live.peis[1].lock = "3 77 deploying\n3 77 done";
  live.peis[1].descriptorProblem = "";
  CHECK(LiveModel::fromYaml(live.toYaml()) == live);
  const auto text = live.toText();
  CHECK_THAT(text, Contains("PEIS 3 'vac'"));
  CHECK_THAT(text, Contains("component robot: waiting (position)"));
  CHECK_THAT(text, Contains("link mi-position <- 2.position.vac"));
  CHECK_THAT(text, Contains("actuator tracking: reqState r=vac"));
  CHECK_THAT(text, Contains("config.lock: 3 77 done"));
  CHECK_THAT(live.toJson(), Contains("\"links\":{\"mi-position\":\"2.position.vac\"}"));
  try {
    LiveModel::fromYaml("peis:\n  - {id: 1, name: a, bogus: 2}\n", "m.live");
    FAIL("no error");
  } catch (const peis::Error& e) {
    CHECK_THAT(std::string(e.what()), Contains("m.live:2:") && Contains("unknown key 'bogus'"));
  }
}

TEST_CASE("a configuration becomes meta tuples and activations", "[unit][meta-runtime]") {
  const auto result = planHome(home());
  REQUIRE(result.ok());
  const auto desired = desiredState(result.configuration);
  CHECK(desired.tuples.at(3).at("mi-position") == "2.position.vac");
  CHECK(desired.tuples.at(2).at("mi-image") == "1.image");
  CHECK(desired.tuples.at(2).at("tracking.reqState") == "r=vac");
  CHECK(desired.tuples.count(1) == 0);  // the camera has nothing to switch
  CHECK(switchedOffValue("mi-x") == "");
  CHECK(switchedOffValue("tracking.reqState") == "off");

  // Two instances on one actuator: both bindings, sorted.
  Configuration two;
  ActiveInstance a{"t", 2, "tracker", "track", {{"?r", "vac"}}, "tracking", 2};
  ActiveInstance b{"t", 2, "tracker", "track", {{"?r", "pippi"}}, "tracking", 2};
  two.instances = {a, b};
  CHECK(desiredState(two).tuples.at(2).at("tracking.reqState") == "r=pippi r=vac");
}

TEST_CASE("the deployment diff writes only what changes and switches off what is no longer wanted",
          "[unit][meta-runtime]") {
  const auto desired = desiredState(planHome(home()).configuration);
  std::map<std::pair<int, std::string>, std::string> ecology;
  auto current = [&](int peis, const std::string& key) -> std::optional<std::string> {
    auto it = ecology.find({peis, key});
    if (it == ecology.end()) return std::nullopt;
    return it->second;
  };
  // Fresh ecology: every tuple is written.
  auto changes = diffDeployment(desired, {}, current);
  REQUIRE(changes.size() == 2);
  CHECK(changes[0].peis == 2);
  CHECK(changes[0].writes.size() == 2);
  CHECK(changes[0].ownedAfter == std::set<std::string>{"mi-image", "tracking.reqState"});
  CHECK(changes[1].writes.at(0) == TupleWrite{3, "mi-position", "2.position.vac", std::nullopt});

  // Deployed: the same again changes nothing (idempotent).
  for (const auto& c : changes)
    for (const auto& w : c.writes) ecology[{w.peis, w.key}] = w.value;
  std::map<int, std::set<std::string>> owned{{2, {"mi-image", "tracking.reqState"}},
                                             {3, {"mi-position"}}};
  CHECK(diffDeployment(desired, owned, current).empty());
  // A meta tuple written with the producer's name points at the same tuple.
  ecology[{3, "mi-position"}] = "tracker.position.vac";
  auto canonical = [](const std::string& d) {
    return d == "tracker.position.vac" ? std::string("2.position.vac") : d;
  };
  CHECK(diffDeployment(desired, owned, current, canonical).empty());
  CHECK(diffDeployment(desired, owned, current).size() == 1);

  // The next configuration no longer uses the tracker: its tuples are switched off.
  DesiredState next;
  next.tuples[3]["mi-position"] = "3.odometry";
  changes = diffDeployment(next, owned, current, canonical);
  REQUIRE(changes.size() == 2);
  CHECK(changes[0].peis == 2);
  CHECK(changes[0].writes.at(0).key == "mi-image");
  CHECK(changes[0].writes.at(0).value == "");
  CHECK(changes[0].writes.at(1).value == "off");
  CHECK(changes[0].ownedAfter.empty());
  CHECK(changes[1].writes.at(0).value == "3.odometry");
  CHECK(changes[1].writes.at(0).previous == "tracker.position.vac");
  // A key to switch off that is not there (its PEIS restarted) is left absent.
  ecology.erase({2, "mi-image"});
  CHECK(diffDeployment(next, owned, current, canonical)[0].writes.size() == 1);
  // A hand-made link on a PEIS without a record is never touched.
  ecology[{4, "mi-other"}] = "9.x";
  for (const auto& c : diffDeployment(next, owned, current, canonical)) CHECK(c.peis != 4);
}

TEST_CASE("the records of a deployment read back also from bad text", "[unit][meta-runtime]") {
  OwnedRecord record{12, 4711, {"mi-a", "x.reqState"}};
  CHECK(record.format() == "12 4711\nmi-a\nx.reqState\n");
  CHECK(OwnedRecord::parse(record.format()) == record);
  CHECK(OwnedRecord::parse("").keys.empty());
  CHECK(OwnedRecord::parse("garbage\nmi-a\nnot a key\n").keys == std::set<std::string>{"mi-a"});
  CHECK(OwnedRecord{}.format().empty());

  LockLine line{7, 33, true};
  CHECK(line.format() == "7 33 deploying");
  CHECK(LockLine::parse("7 33 deploying") == line);
  CHECK_FALSE(LockLine::parse("7 33 sleeping"));
  CHECK_FALSE(LockLine::parse("7 33 done extra"));
  CHECK_FALSE(LockLine::parse("x 33 done"));
  CHECK(lastLockLine("7 33 deploying\n7 33 done\n")->deploying == false);
  CHECK(lastLockLine("7 33 done\n8 34 deploying")->holder == 34);
  CHECK_FALSE(lastLockLine(""));
  CHECK(lineCount("a\nb") == 2);
  CHECK(lineCount("a\nb\n") == 2);
  CHECK(lineCount("") == 0);
}

TEST_CASE("goal tuples: one goal per line and bad lines named by tuple and line",
          "[unit][meta-runtime]") {
  const auto parsed = parseGoalTuple(
      "position(pippi)@Pippi.mi-position\n\n# a comment\nrun:vac/cleaner/clean\navoid:cam2\n"
      "weather(\n",
      "Emil.config.goal.planner");
  REQUIRE(parsed.goals.information.size() == 1);
  CHECK(parsed.goals.information[0].origin == "Emil.config.goal.planner:1");
  CHECK(parsed.goals.information[0].consumerPeis == "Pippi");
  CHECK(parsed.goals.run.at(0).origin == "Emil.config.goal.planner:4");
  CHECK(parsed.goals.constraints.avoidPeis == std::vector<std::string>{"cam2"});
  CHECK(parsed.goals.constraints.avoidPeisOrigin.at("cam2") == "Emil.config.goal.planner:5");
  REQUIRE(parsed.problems.size() == 1);
  CHECK_THAT(parsed.problems[0], Contains("Emil.config.goal.planner:6: "));
  CHECK(parseGoalTuple("", "x").goals.empty());
  CHECK(formatGoalTuple({"a@b.mi-c", "d"}) == "a@b.mi-c\nd\n");

  GoalStatusLine line{12, "config.goal.planner", 3, GoalState::Infeasible, "no producer\nof x"};
  CHECK(line.format() == "12.config.goal.planner 3 infeasible: no producer of x");
  const auto back = GoalStatusLine::parse(line.format());
  REQUIRE(back);
  CHECK(back->owner == 12);
  CHECK(back->key == "config.goal.planner");
  CHECK(back->state == GoalState::Infeasible);
  CHECK(back->reason == "no producer of x");
  CHECK_FALSE(GoalStatusLine::parse("12.config.goal.x 3 maybe"));
  CHECK_FALSE(GoalStatusLine::parse("x.y 3 deployed"));
  CHECK(
      parseGoalStatus("1.config.goal.a 1 deployed\nbad\n2.config.goal.b 4 pending: why\n").size() ==
      2);
}

TEST_CASE("the monitor blames a dead PEIS or an error or a lost precondition at once",
          "[unit][meta-runtime]") {
  auto live = home();
  const auto result = planHome(live);
  REQUIRE(result.ok());
  HealthMonitor monitor(MonitorPolicy{2000ms, 2000ms});
  const auto t0 = MonitorClock::time_point(10s);
  monitor.deployed(result.configuration, live.toModel(), t0);
  CHECK(monitor.observe(live, t0 + 1ms).empty());

  auto dead = live;
  dead.peis[1].alive = false;
  auto failures = monitor.observe(dead, t0 + 5ms);
  REQUIRE(failures.size() == 1);
  CHECK(failures[0].kind == FailureKind::PeisGone);
  CHECK(failures[0].instance.toString() == "tracker/tracker/track{?r=vac}");
  CHECK(monitor.observe(dead, t0 + 6ms).empty());  // reported once

  monitor.deployed(result.configuration, live.toModel(), t0);
  auto error = live;
  error.peis[0].status = "error";
  error.peis[0].causes = "lens cap on";
  failures = monitor.observe(error, t0 + 5ms);
  REQUIRE(failures.size() == 1);
  CHECK(failures[0].kind == FailureKind::ComponentError);
  CHECK_THAT(failures[0].cause, Contains("lens cap on"));

  monitor.deployed(result.configuration, live.toModel(), t0);
  auto unseen = live;
  unseen.peis[1].facts.clear();
  failures = monitor.observe(unseen, t0 + 5ms);
  REQUIRE(failures.size() == 1);
  CHECK(failures[0].kind == FailureKind::PreconditionLost);
  CHECK_THAT(failures[0].cause, Contains("sees(vac)"));
}

TEST_CASE("a stale input blames its producer only after the grace period", "[unit][meta-runtime]") {
  auto live = home();
  const auto result = planHome(live);
  HealthMonitor monitor(MonitorPolicy{2000ms, 1000ms});
  const auto t0 = MonitorClock::time_point(10s);
  monitor.deployed(result.configuration, live.toModel(), t0);
  live.peis[2].links["mi-position"] = "2.position.vac";
  live.peis[1].links["mi-image"] = "cam.image";
  auto stale = live;
  stale.peis[2].status = "waiting";
  stale.peis[2].causes = "position";
  // A frozen producer: the consumer waits for less than the grace period.
  CHECK(monitor.observe(stale, t0 + 3s).empty());
  CHECK(monitor.nextCheck() == t0 + 5s);
  CHECK(monitor.observe(stale, t0 + 4900ms).empty());
  CHECK(monitor.observe(live, t0 + 4950ms).empty());  // it delivered again: evidence gone
  CHECK_FALSE(monitor.nextCheck());
  CHECK(monitor.observe(stale, t0 + 6s).empty());  // waiting anew
  auto failures = monitor.observe(stale, t0 + 8s);
  REQUIRE(failures.size() == 1);
  CHECK(failures[0].kind == FailureKind::StaleInput);
  CHECK(failures[0].instance.toString() == "tracker/tracker/track{?r=vac}");
  CHECK_THAT(failures[0].cause, Contains("input position of vac stale for 2.0 s"));

  // The producer itself waits on its camera: it is not blamed (its supplier is).
  monitor.deployed(result.configuration, live.toModel(), t0);
  auto upstream = stale;
  upstream.peis[1].status = "waiting";
  upstream.peis[1].causes = "image";
  CHECK(monitor.observe(upstream, t0 + 3s).empty());
  failures = monitor.observe(upstream, t0 + 6s);
  REQUIRE(failures.size() == 1);
  CHECK(failures[0].instance.toString() == "cam/camera/capture");
  // A consumer pointed elsewhere (drift) is not judged here.
  monitor.deployed(result.configuration, live.toModel(), t0);
  auto elsewhere = stale;
  elsewhere.peis[2].links["mi-position"] = "3.odometry";
  CHECK(monitor.observe(elsewhere, t0 + 3s).empty());
  CHECK(monitor.observe(elsewhere, t0 + 9s).empty());
}

TEST_CASE("failed parts come back after a hold and a silent producer is retried with back-off",
          "[unit][meta-runtime]") {
  auto live = home();
  FailedParts parts(1000ms, 30s);
  const auto t0 = MonitorClock::time_point(100s);
  Failure gone{FailureKind::PeisGone, *InstanceSelector::parse("tracker/tracker/track", nullptr), 2,
               1002, "gone"};
  CHECK(parts.add(gone, t0));
  CHECK_FALSE(parts.add(gone, t0));
  auto dead = live;
  dead.peis[1].alive = false;
  CHECK(parts.recovered(dead, t0 + 1s).empty());
  CHECK(parts.recovered(live, t0 + 2s).empty());  // healthy from now…
  CHECK(parts.nextCheck() == t0 + 3s);
  CHECK(parts.recovered(dead, t0 + 2500ms).empty());  // …not for long
  CHECK(parts.recovered(live, t0 + 3s).empty());
  CHECK(parts.recovered(live, t0 + 4s).size() == 1);
  CHECK(parts.empty());

  Failure silent{FailureKind::StaleInput, *InstanceSelector::parse("cam/camera/capture", nullptr),
                 1, 1001, "not delivered"};
  parts.add(silent, t0);
  CHECK(parts.recovered(live, t0 + 29s).empty());
  CHECK(parts.recovered(live, t0 + 30s).empty());
  CHECK(parts.recovered(live, t0 + 31s).size() == 1);
  parts.add(silent, t0 + 40s);  // failed again: twice as long
  CHECK(parts.recovered(live, t0 + 40s + 59s).empty());
  CHECK(parts.recovered(live, t0 + 40s + 60s).empty());
  CHECK(parts.recovered(live, t0 + 40s + 61s).size() == 1);
  // …unless its PEIS restarts.
  parts.add(silent, t0 + 200s);
  auto restarted = live;
  restarted.peis[0].incarnation = 5;
  CHECK(parts.recovered(restarted, t0 + 201s).empty());
  CHECK(parts.recovered(restarted, t0 + 202s).size() == 1);

  CHECK(parts.add({FailureKind::PreconditionLost, gone.instance, 2, 0, "x"}, t0) == false);

  CHECK(worthSwitching(10, 7.9, 0.2));
  CHECK(worthSwitching(9.1, 7, 0.2));
  CHECK_FALSE(worthSwitching(10, 8.5, 0.2));
  CHECK_FALSE(worthSwitching(10, 10, 0));
}

TEST_CASE("after a failure the planner avoids the failed instance", "[unit][meta-runtime]") {
  const auto live = home();
  const auto before = planHome(live);
  REQUIRE(before.configuration.cost == Approx(1 + 2 + 1 + 1));  // camera, tracker, two lan links
  const auto after = planHome(live, {*InstanceSelector::parse("tracker/tracker/track", nullptr)});
  REQUIRE(after.ok());
  CHECK(after.configuration.links.at(0).toString() == "vac.mi-position <- vac.odometry");
  const auto producers =
      producersOf(before.configuration, live.toModel(), before.configuration.links.back());
  REQUIRE(producers.size() == 1);
  CHECK(producers[0].functionality == "track");
}

TEST_CASE("event tuples: keys in order and text for a person", "[unit][meta-runtime]") {
  CHECK(eventKey(42) == "config.event.0000000042");
  CHECK(eventNumber("config.event.0000000042") == 42u);
  CHECK_FALSE(eventNumber("config.event.x"));
  CHECK_FALSE(eventNumber("config.goal.x"));
  CHECK(eventKey(9) < eventKey(10));
  const auto e = ConfigEvent::parse(3, peis::Timestamp(std::chrono::seconds(1700000000)),
                                    "failure cam/camera/capture: PEIS cam is gone");
  CHECK(e.kind == "failure");
  CHECK(e.text == "cam/camera/capture: PEIS cam is gone");
  CHECK(e.data() == "failure cam/camera/capture: PEIS cam is gone");
  CHECK_THAT(e.format(), Contains(".000  failure      cam/camera/capture"));
}
