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
