// The plan executor's state machine: every transition, with the commands it
// emits (no network).
#include "plan_runner.h"

#include <catch2/catch.hpp>

using namespace peis::executor;
using Kind = Command::Kind;
using peis::exec::ExecState;
using peis::exec::ExecStatus;

namespace {

const std::string kPos = "position(pippi)@Pippi.mi-position";

std::vector<PlanStep> wakeUp() {
  return {{"GoTo", {"Pippi", "bed"}, {kPos}},
          {"Talk", {"Pippi", "wakeup"}, {}},
          {"GoTo", {"Pippi", "sofa"}, {kPos}}};
}

ActionMap actions() {
  ActionMap map;
  map.add("Talk=$1-voice:Talk($2)");
  return map;
}

Command send(std::string peis, std::string goal) {
  return {Kind::SendGoal, {}, {std::move(peis), std::move(goal)}, {}};
}
Command post(std::vector<std::string> needs) { return {Kind::PostNeeds, std::move(needs), {}, {}}; }
Command withdraw(std::vector<std::string> needs) {
  return {Kind::WithdrawNeeds, std::move(needs), {}, {}};
}
ExecStatus status(ExecState s, std::uint64_t id, std::string action, std::string cause = {}) {
  return {s, id, std::move(action), std::move(cause)};
}

}  // namespace

TEST_CASE("the action map: default dispatch, rules, and their errors", "[unit]") {
  ActionMap map = actions();
  std::string why;
  CHECK(map.map({"GoTo", {"Pippi", "bed"}, {}}, why) == Dispatch{"Pippi", "GoTo(bed)"});
  CHECK(map.map({"Talk", {"Pippi", "wakeup"}, {}}, why) == Dispatch{"Pippi-voice", "Talk(wakeup)"});
  CHECK_FALSE(map.map({"Talk", {"Pippi"}, {}}, why));
  CHECK(why == "'Talk($2)' uses $2 but the step has 1 arguments");
  CHECK_FALSE(map.map({"Wait", {}, {}}, why));
  CHECK(why.find("no PEIS") != std::string::npos);
  CHECK_THROWS_AS(map.add("GoTo"), std::invalid_argument);
  CHECK_THROWS_AS(map.add("GoTo=Pippi"), std::invalid_argument);
  CHECK_THROWS_AS(map.add("=Pippi:GoTo"), std::invalid_argument);
  map.add("Photo=Astrid:Photo(bad,)");
  CHECK_FALSE(map.map({"Photo", {}, {}}, why));
  CHECK(why.find("is not an action") != std::string::npos);
}

TEST_CASE("a plan runs step by step: deploy, dispatch, execute, withdraw", "[unit]") {
  PlanRunner runner(actions());
  CHECK(runner.phase() == Phase::Idle);
  // idle -> deploying: the first step's needs are posted.
  CHECK(runner.start(wakeUp()) == std::vector<Command>{post({kPos})});
  CHECK(runner.phase() == Phase::Deploying);
  // deploying -> dispatching: the ExecGoal is sent.
  CHECK(runner.onDeployed() == std::vector<Command>{send("Pippi", "GoTo(bed)")});
  CHECK(runner.phase() == Phase::Dispatching);
  // dispatching -> executing once the write is acknowledged with its id.
  CHECK(runner.onGoalAccepted(11).empty());
  CHECK(runner.phase() == Phase::Executing);
  CHECK(runner.goalId() == 11u);
  // running: stays; another goal's status: ignored.
  CHECK(runner.onStatus(status(ExecState::Running, 11, "GoTo(bed)")).empty());
  CHECK(runner.onStatus(status(ExecState::Success, 10, "GoTo(bed)")).empty());
  CHECK(runner.ignoredEvents() == 1);
  CHECK(runner.phase() == Phase::Executing);
  // success -> the next step needs nothing: withdraw, dispatch at once.
  CHECK(runner.onStatus(status(ExecState::Success, 11, "GoTo(bed)")) ==
        std::vector<Command>{withdraw({kPos}), send("Pippi-voice", "Talk(wakeup)")});
  CHECK(runner.completed().size() == 1);
  runner.onGoalAccepted(3);
  // The third step needs the position again: posted anew.
  CHECK(runner.onStatus(status(ExecState::Success, 3, "Talk(wakeup)")) ==
        std::vector<Command>{post({kPos})});
  runner.onDeployed();
  runner.onGoalAccepted(12);
  // The last success: withdraw and finish.
  CHECK(runner.onStatus(status(ExecState::Success, 12, "GoTo(sofa)")) ==
        std::vector<Command>{withdraw({kPos}), {Kind::Finished, {}, {}, "success"}});
  CHECK(runner.phase() == Phase::Succeeded);
  CHECK(runner.completed().size() == 3);
}

TEST_CASE("needs shared by consecutive steps stay deployed", "[unit]") {
  PlanRunner runner(actions());
  std::vector<PlanStep> plan{{"GoTo", {"Pippi", "bed"}, {kPos}},
                             {"GoTo", {"Pippi", "sofa"}, {kPos, "x@y.mi-z"}}};
  runner.start(plan);
  runner.onDeployed();
  runner.onGoalAccepted(1);
  CHECK(runner.onStatus(status(ExecState::Success, 1, "GoTo(bed)")) ==
        std::vector<Command>{post({"x@y.mi-z"})});
}

TEST_CASE("a status that overtakes the write's acknowledgement is not lost", "[unit]") {
  PlanRunner runner(actions());
  runner.start({{"GoTo", {"Pippi", "bed"}, {}}});
  CHECK(runner.phase() == Phase::Dispatching);  // no needs: dispatched at once
  CHECK(runner.onStatus(status(ExecState::Success, 5, "GoTo(bed)")).empty());
  CHECK(runner.onGoalAccepted(5) == std::vector<Command>{{Kind::Finished, {}, {}, "success"}});
}

TEST_CASE("failures replan from the current state; a new plan starts over", "[unit]") {
  PlanRunner runner(actions(), 2);
  runner.start(wakeUp());
  runner.onDeployed();
  runner.onGoalAccepted(1);
  // executing -> replanning on a failed status, with the needs withdrawn.
  const auto out = runner.onStatus(status(ExecState::Failed, 1, "GoTo(bed)", "no path"));
  REQUIRE(out.size() == 2);
  CHECK(out[0] == withdraw({kPos}));
  CHECK(out[1].kind == Kind::RequestPlan);
  CHECK(out[1].text == "GoTo(Pippi, bed) failed on Pippi: no path");
  CHECK(runner.phase() == Phase::Replanning);
  // replanning -> deploying with the new plan.
  CHECK(runner.onPlan({{"GoTo", {"Pippi", "sofa"}, {kPos}}}) == std::vector<Command>{post({kPos})});
  CHECK(runner.phase() == Phase::Deploying);
  // deploying -> replanning when the configuration cannot be deployed.
  const auto notDeployed = runner.onDeployFailed("no producer of position(pippi)");
  CHECK(notDeployed.back().kind == Kind::RequestPlan);
  CHECK(notDeployed.back().text.find("not deployed: no producer") != std::string::npos);
  // Out of replans: failed with the cause.
  runner.onPlan({{"GoTo", {"Pippi", "sofa"}, {}}});
  const auto refused = runner.onGoalRefused("ExecGoal refused: unknown action");
  CHECK(refused.back().kind == Kind::Finished);
  CHECK(refused.back().text.find("failed: GoTo(Pippi, sofa) refused by Pippi") == 0);
  CHECK(refused.back().text.find("gave up after 2 replans") != std::string::npos);
  CHECK(runner.phase() == Phase::Failed);
}

TEST_CASE("no new plan ends the run failed with both causes", "[unit]") {
  PlanRunner runner(actions());
  runner.start(wakeUp());
  runner.onDeployed();
  runner.onGoalAccepted(1);
  runner.onStatus(status(ExecState::Failed, 1, "GoTo(bed)", "blocked"));
  CHECK(runner.onNoPlan("the goal is unreachable") ==
        std::vector<Command>{{Kind::Finished,
                              {},
                              {},
                              "failed: GoTo(Pippi, bed) failed on Pippi: blocked; no new plan: the "
                              "goal is unreachable"}});
  CHECK(runner.phase() == Phase::Failed);
  // A finished runner can start again.
  CHECK(runner.start(wakeUp()).front() == post({kPos}));
}

TEST_CASE("timeouts fail the phase they were armed in, and only that one", "[unit]") {
  PlanRunner runner(actions());
  runner.start(wakeUp());
  const auto deployingEpoch = runner.epoch();
  runner.onDeployed();
  CHECK(runner.onTimeout(deployingEpoch).empty());  // stale timer
  const auto dispatchingEpoch = runner.epoch();
  auto out = runner.onTimeout(dispatchingEpoch);
  CHECK(out.back().kind == Kind::RequestPlan);
  CHECK(out.back().text.find("no answer (timed out)") != std::string::npos);
  runner.onPlan(wakeUp());
  CHECK(runner.onTimeout(runner.epoch()).back().text.find("not deployed: timed out") !=
        std::string::npos);
  runner.onPlan({{"GoTo", {"Pippi", "bed"}, {}}});
  runner.onGoalAccepted(4);
  CHECK(runner.onTimeout(runner.epoch()).back().text == "GoTo(Pippi, bed) on Pippi timed out");
}

TEST_CASE("events out of phase are ignored and counted", "[unit]") {
  PlanRunner runner(actions());
  CHECK(runner.onDeployed().empty());
  CHECK(runner.onDeployFailed("x").empty());
  CHECK(runner.onGoalAccepted(1).empty());
  CHECK(runner.onGoalRefused("x").empty());
  CHECK(runner.onPlan({}).empty());
  CHECK(runner.onNoPlan("x").empty());
  CHECK(runner.onStatus(status(ExecState::Success, 1, "GoTo(bed)")).empty());
  CHECK(runner.ignoredEvents() == 7);
  CHECK(runner.phase() == Phase::Idle);
  runner.start(wakeUp());
  CHECK(runner.start(wakeUp()).empty());  // already running
  CHECK(runner.ignoredEvents() == 8);
}

TEST_CASE("an undispatchable step and an empty plan", "[unit]") {
  PlanRunner runner(actions());
  CHECK(runner.start({}) == std::vector<Command>{{Kind::Finished, {}, {}, "success"}});
  const auto out = runner.start({{"Wait", {}, {}}});
  CHECK(out.back().kind == Kind::RequestPlan);
  CHECK(out.back().text.find("cannot dispatch Wait") == 0);
}

#include "plan_text.h"

TEST_CASE("plans, needs and static links as text", "[unit]") {
  const auto plan = parsePlan(
      "GoTo(Pippi, bed) | position(pippi)@Pippi.mi-position ; Talk(Pippi, wakeup); "
      "GoTo(Pippi,sofa)");
  REQUIRE(plan.size() == 3);
  CHECK(plan[0] == PlanStep{"GoTo", {"Pippi", "bed"}, {kPos}});
  CHECK(plan[1].needs.empty());
  CHECK(formatPlan(plan) ==
        "GoTo(Pippi, bed) | position(pippi)@Pippi.mi-position; Talk(Pippi, wakeup); GoTo(Pippi, "
        "sofa)");
  CHECK(parsePlan(formatPlan(plan)) == plan);
  CHECK(parsePlan("  ").empty());
  CHECK_THROWS_WITH(parsePlan("GoTo(bed"), Catch::Contains("plan step 'GoTo(bed'"));
  CHECK_THROWS_WITH(parsePlan("GoTo(bed) | position"),
                    Catch::Contains("is not INFORMATION@PEIS.KEY"));
  const auto need = parseNeed(kPos);
  REQUIRE(need);
  CHECK(need->information == "position(pippi)");
  CHECK(need->consumer == "Pippi");
  CHECK(need->key == "mi-position");
  CHECK_FALSE(parseNeed("position(pippi)@Pippi"));
  CHECK_FALSE(parseNeed("@Pippi.mi-position"));
  const auto link = parseStaticLink("position(pippi)=tracker.position.Pippi");
  CHECK(link.producer == "tracker");
  CHECK(link.key == "position.Pippi");
  CHECK_THROWS_AS(parseStaticLink("position(pippi)"), std::invalid_argument);
  CHECK_THROWS_AS(parseStaticLink("position(pippi)=tracker."), std::invalid_argument);
}
