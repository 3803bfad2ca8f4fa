// The executor's task planning: tasks parsed, the state after the steps
// done (effects applied, free variables bound from the state), and
// replanning from it — on the home domain's wake-up problem.
#include "task_planning.h"

#include <catch2/catch.hpp>

using namespace peis::executor;
using Catch::Matchers::Contains;
using peis::meta::task::Domain;
using peis::meta::task::Problem;

namespace {

const Domain& home() {
  static const Domain d = Domain::fromFile(PEIS_SOURCE_DIR "/meta/domains/home.domain.yaml");
  return d;
}
// javaspace-peis-middleware.txt §5: Emil plans, Pippi acts (Emil is no
// actor here, so the plan is unique).
const Problem& wakeup() {
  static const Problem p = Problem::fromYaml(R"yaml(problem: wakeup
domain: home
objects: {pippi: robot, kitchen: place, bed: place, sofa: place, johanna: person, wakeup: message}
init: ["at(pippi, kitchen)", "in(johanna, bed)", "asleep(johanna)", "wakes(wakeup)"]
goal: ["awake(johanna)"]
)yaml",
                                             "wakeup.yaml");
  return p;
}

bool holds(const std::vector<peis::Term>& state, const std::string& atom) {
  return std::find(state.begin(), state.end(), *peis::Term::parse(atom)) != state.end();
}

}  // namespace

TEST_CASE("executor: tasks are goal literals separated by commas", "[unit][executor]") {
  const auto goal = parseTask("awake(johanna), at(pippi, sofa), not asleep(johanna)");
  REQUIRE(goal.size() == 3);
  CHECK(goal[0].atom.toString() == "awake(johanna)");
  CHECK(goal[1].atom.toString() == "at(pippi,sofa)");
  CHECK(goal[2].negated);
  CHECK_THROWS_WITH(parseTask("awake(johanna), "), Contains("is not an atom"));
  CHECK_THROWS_WITH(parseTask("at(?r, sofa)"), Contains("has a variable"));
  CHECK_THROWS_WITH(parseTask("at(pippi, sofa"), Contains("'at(pippi, sofa' is not an atom"));
}

TEST_CASE("executor: Emil's task is planned and replanned from the state reached",
          "[unit][executor]") {
  const auto goal = parseTask("awake(johanna), at(pippi, sofa)");
  const auto plan = planFrom(home(), wakeup(), goal);
  REQUIRE(plan.found);
  CHECK(plan.text == "GoTo(pippi, bed); Talk(pippi, wakeup); GoTo(pippi, sofa)");
  REQUIRE(plan.steps.size() == 3);
  CHECK(plan.steps[0].needs == std::vector<std::string>{"position(pippi)@pippi.mi-position"});
  CHECK(plan.steps[1].needs.empty());

  // After the first step, Pippi is at the bed (GoTo's ?from was bound to the
  // kitchen by the state, and deleted).
  const auto after = stateAfter(home(), wakeup(), {plan.steps[0]});
  CHECK(holds(after, "at(pippi,bed)"));
  CHECK_FALSE(holds(after, "at(pippi,kitchen)"));
  CHECK(holds(after, "asleep(johanna)"));
  // Talk failed: the new plan starts from there.
  const auto again = planFrom(home(), wakeup(), goal, {plan.steps[0]});
  REQUIRE(again.found);
  CHECK(again.text == "Talk(pippi, wakeup); GoTo(pippi, sofa)");
  // Everything done: nothing left to do.
  const auto done = planFrom(home(), wakeup(), goal, plan.steps);
  CHECK(done.found);
  CHECK(done.steps.empty());
  // Steps that do not fit the domain or the state.
  CHECK_THROWS_WITH(stateAfter(home(), wakeup(), {{"Fly", {"pippi", "moon"}, {}}}),
                    Contains("no action Fly"));
  CHECK_THROWS_WITH(stateAfter(home(), wakeup(), {{"Talk", {"pippi", "wakeup"}, {}}}),
                    Contains("cannot be applied"));
  // A goal nobody can reach.
  const auto none = planFrom(home(), wakeup(), parseTask("at(johanna, sofa)"));
  CHECK_FALSE(none.found);
}

TEST_CASE("executor: a failed step's on-failure effects shape the replan (the dark photo)",
          "[unit][executor]") {
  const auto photo = Problem::fromFile(PEIS_SOURCE_DIR "/scenarios/tasks/photo-sofa.problem.yaml");
  const auto goal = parseTask("photo(sofa)");
  const auto first = planFrom(home(), photo, goal);
  REQUIRE(first.found);
  CHECK(first.text == "GoTo(astrid, sofa); TakePhoto(astrid, sofa)");
  const std::vector<PlanStep> done{first.steps[0]};
  const FailedStep dark{first.steps[1],
                        "TakePhoto(astrid, sofa) failed on astrid-camera: too dark (brightness "
                        "31.5 < 70)",
                        1};
  const auto state = stateAfter(home(), photo, done, {dark});
  CHECK(holds(state, "at(astrid, sofa)"));
  CHECK_FALSE(holds(state, "lit(sofa)"));
  const auto replanned = planFrom(home(), photo, goal, done, {dark});
  REQUIRE(replanned.found);
  CHECK(replanned.text == "TurnOn(lamp); TakePhoto(astrid, sofa)");
  CHECK(replanned.steps[0].needs == std::vector<std::string>{"lamp-level(lamp)"});
  // The photo is taken again before the light has changed: dark again. What
  // the first failure taught is kept (else TurnOn would not fit the state
  // and there would be no plan): TurnOn again, then the photo.
  const std::vector<PlanStep> twice{first.steps[0], replanned.steps[0]};
  const FailedStep darkAgain{replanned.steps[1], dark.cause, 2};
  const auto again = planFrom(home(), photo, goal, twice, {dark, darkAgain});
  REQUIRE(again.found);
  CHECK(again.text == "TurnOn(lamp); TakePhoto(astrid, sofa)");
  // A cause the domain says nothing about teaches nothing: a plain retry.
  const FailedStep other{first.steps[1], "TakePhoto(astrid, sofa) on astrid-camera timed out", 1};
  CHECK(planFrom(home(), photo, goal, done, {other}).text == "TakePhoto(astrid, sofa)");
}

TEST_CASE("executor: set: rules are carried out by the executor's own write", "[unit][executor]") {
  ActionMap map;
  map.add("TurnOn=set:LightValue=100");
  std::string why;
  const auto d = map.map(PlanStep{"TurnOn", {"lamp"}, {}}, why);
  REQUIRE(d);
  CHECK(d->setKey == "LightValue");
  CHECK(d->goal == "100");
  CHECK(d->peis.empty());
  CHECK_THROWS_WITH(map.add("TurnOn=set:LightValue"), Contains("expected NAME=set:KEY=VALUE"));
}
