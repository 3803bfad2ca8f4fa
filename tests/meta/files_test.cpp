// Unit tests of the meta-level's files: the model file, goal files and
// arguments, task domains and problems. Every error names file:line.
#include <catch2/catch.hpp>

#include "peis/error.h"
#include "peis/meta/goals.h"
#include "peis/meta/model.h"
#include "peis/meta/task.h"

using namespace peis::meta;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

namespace {

template <typename F>
std::string failure(F&& parse) {
  try {
    parse();
  } catch (const peis::Error& e) {
    return e.what();
  }
  FAIL("no error");
  return {};
}

}  // namespace

TEST_CASE("a model file round-trips and its errors name the line", "[unit][meta-files]") {
  const char* text = R"yaml(
link-costs: {local: 0, lan: 2, radio: 5}
peis:
  - name: a
    id: 3
    radio: true
    components:
      - component: c
        functionalities:
          - {name: f, outputs: [{name: o, type: "t(x)"}]}
  - {name: b, alive: false}
link-overrides: [{producer: a, consumer: b, cost: 7}]
facts: ["p(x, y)", {fact: q, publisher: a}]
failed: ["a/c/f{?v=1}"]
)yaml";
  const auto m = Model::fromYaml(text, "m.yaml");
  CHECK(m.peis.size() == 2);
  CHECK(m.linkCost(m.peis[0], m.peis[1]) == 7);
  CHECK(m.linkCost(m.peis[1], m.peis[0]) == 5);  // radio
  CHECK(m.linkKind(m.peis[0], m.peis[0]) == LinkKind::Local);
  CHECK(m.facts.at(1).publisher == "a");
  CHECK(m.failed.at(0).binding.at("?v") == "1");
  CHECK(Model::fromYaml(m.toYaml(), "again") == m);
  CHECK(m.findPeis("3") == &m.peis[0]);

  CHECK_THAT(failure([] { Model::fromYaml("peis: [\n", "m.yaml"); }),
             StartsWith("m.yaml:") && Contains("not valid YAML"));
  CHECK_THAT(failure([] { Model::fromYaml("peis: []\nbogus: 1\n", "m.yaml"); }),
             StartsWith("m.yaml:2:") && Contains("unknown key 'bogus'"));
  CHECK_THAT(failure([] { Model::fromYaml("peis:\n  - {name: a}\n  - {name: a}\n", "m.yaml"); }),
             StartsWith("m.yaml:3:") && Contains("declared twice"));
  CHECK_THAT(failure([] { Model::fromYaml("facts: [\"p(?x)\"]\n", "m.yaml"); }),
             StartsWith("m.yaml:1:") && Contains("variable"));
  CHECK_THAT(failure([] {
               Model::fromYaml(
                   "peis:\n  - name: a\n    components:\n      - component: c\n        "
                   "functionalities: [{name: f, cost: -1}]\n",
                   "m.yaml");
             }),
             StartsWith("m.yaml:5:") && Contains("cost"));
  CHECK_THAT(failure([] {
               Model::fromYaml(
                   "peis:\n  - name: a\n    components: [{descriptor: /nonexistent.yaml}]\n",
                   "m.yaml");
             }),
             StartsWith("m.yaml:3:") && Contains("cannot open"));
  CHECK_THAT(failure([] {
               Model::fromYaml("link-overrides: [{producer: x, consumer: y, cost: 1}]\n", "m.yaml");
             }),
             Contains("unknown PEIS 'x'"));
  CHECK_THAT(failure([] { Model::fromYaml("peis:\n  - {name: a, id: -4}\n", "m.yaml"); }),
             StartsWith("m.yaml:2:") && Contains("id"));
  // Missing keys are named with the line of the mapping that lacks them.
  CHECK_THAT(failure([] { Model::fromYaml("peis:\n  - {name: a}\n  - {id: 4}\n", "m.yaml"); }),
             StartsWith("m.yaml:3:") && Contains("PEIS name is missing"));
  CHECK_THAT(failure([] {
               Model::fromYaml("peis:\n  - name: a\n    components:\n      - functionalities: []\n",
                               "m.yaml");
             }),
             StartsWith("m.yaml:4:") && Contains("component is missing"));
  CHECK_THAT(failure([] {
               Model::fromYaml(
                   "peis: [{name: a}]\nlink-overrides:\n  - {producer: a, consumer: a}\n",
                   "m.yaml");
             }),
             StartsWith("m.yaml:3:") && Contains("cost is missing"));
  CHECK_THAT(failure([] { Model::fromYaml("facts:\n  - {publisher: a}\n", "m.yaml"); }),
             StartsWith("m.yaml:2:") && Contains("fact is missing"));
  CHECK_THAT(failure([] { Model::fromFile("/nonexistent/model.yaml"); }),
             Contains("cannot open the model file"));
}

TEST_CASE("goals from a file and from arguments", "[unit][meta-files]") {
  const auto g = Goals::fromYaml(R"yaml(
goals:
  - position(vac)@vac.mi-position
  - {information: "activity(johanna, kitchen)"}
  - {run: "vac/cleaner/clean{?parcel=box}"}
avoid: [cam2, "ceiling/tracker/track{?robot=vac}"]
prefer: [vac/cleaner/odometry]
)yaml",
                                 "g.yaml");
  REQUIRE(g.information.size() == 2);
  CHECK(g.information[0].consumerPeis == "vac");
  CHECK(g.information[0].consumerKey == "mi-position");
  CHECK(g.information[0].origin == "g.yaml:3");
  CHECK(g.information[1].information.toString() == "activity(johanna,kitchen)");
  CHECK(g.information[1].consumerPeis.empty());
  CHECK(g.run.at(0).instance.binding.at("?parcel") == "box");
  CHECK(g.constraints.avoidPeis == std::vector<std::string>{"cam2"});
  CHECK(g.constraints.avoid.at(0).functionality == "track");
  CHECK(Goals::fromYaml(g.toYaml(), "again").information.size() == 2);
  const auto a = Goals::fromArguments({"position(vac)@vac.mi-position", "run:vac/cleaner/clean",
                                       "avoid:cam2", "prefer:*/tracker/track"});
  CHECK(a.information.size() == 1);
  CHECK(a.run.size() == 1);
  CHECK(a.constraints.prefer.at(0).peis.empty());

  CHECK_THAT(failure([] { Goals::fromYaml("goals:\n  - \"position(?r)\"\n", "g.yaml"); }),
             StartsWith("g.yaml:2:") && Contains("variables"));
  CHECK_THAT(failure([] { Goals::fromYaml("goals:\n  - x@vac\n", "g.yaml"); }),
             StartsWith("g.yaml:2:") && Contains("PEIS.KEY"));
  CHECK_THAT(failure([] { Goals::fromYaml("goals:\n  - x@vac.position\n", "g.yaml"); }),
             Contains("meta input"));
  CHECK_THAT(
      failure([] { Goals::fromYaml("goals:\n  - {run: a/b/c, information: x}\n", "g.yaml"); }),
      StartsWith("g.yaml:2:") && Contains("not both"));
  CHECK_THAT(failure([] { Goals::fromYaml("wishes: []\n", "g.yaml"); }),
             StartsWith("g.yaml:1:") && Contains("unknown key 'wishes'"));
  CHECK_THAT(failure([] { Goals::fromYaml("goals: [\n", "g.yaml"); }), Contains("not valid YAML"));
  CHECK_THAT(
      failure([] { Goals::fromYaml("goals:\n  - x\n  - {consumer: vac.mi-x}\n", "g.yaml"); }),
      StartsWith("g.yaml:3:") && Contains("information is missing"));
  // A goal list without `goals:` is named, with the keys a goal file has.
  CHECK_THAT(failure([] { Goals::fromYaml("- position(vac)@vac.mi-position\n", "g.yaml"); }),
             StartsWith("g.yaml:1:") && Contains("must be a mapping") && Contains("goals"));
  CHECK_THAT(failure([] {
               Goals::fromArguments({"ok", "run:vac"});
             }),
             Contains("argument 2") && Contains("PEIS/COMPONENT/FUNCTIONALITY"));
  CHECK_THAT(failure([] { Goals::fromArguments({"f(a"}); }), Contains("argument 1"));
  CHECK_THAT(failure([] { Goals::fromArguments({"prefer:a/b/c{x}"}); }), Contains("?var=value"));
}

TEST_CASE("task domains and problems: plans and errors", "[unit][task]") {
  const char* domain = R"yaml(
domain: d
actions:
  - name: Go
    parameters: {robot: robot, to: place}
    preconditions: ["at(?robot, ?from)", "link(?from, ?to)"]
    effects: ["at(?robot, ?to)", "not at(?robot, ?from)"]
    needs: ["position(?robot)@?robot.mi-position"]
  - name: Lift
    parameters: {robot: robot}
    preconditions: ["at(?robot, b)", "not lifted"]
    effects: [lifted]
    cost: 3
)yaml";
  const auto d = task::Domain::fromYaml(domain, "d.yaml");
  auto p = task::Problem::fromYaml(R"yaml(
problem: p
domain: d
objects: {r: robot, a: place, b: place, c: place}
init: ["at(r, a)", "link(a, b)", "link(b, c)", "link(a, c)"]
goal: [lifted, "at(r, c)"]
)yaml",
                                   "p.yaml");
  const auto plan = task::planTask(d, p);
  REQUIRE(plan.found);
  CHECK(plan.optimal);
  CHECK(plan.cost == 5);  // Go(r, b) 1, Lift(r) 3, Go(r, c) 1
  REQUIRE(plan.steps.size() == 3);
  CHECK(plan.steps[0].toString() == "Go(r, b)");
  CHECK(plan.steps[0].needs == std::vector<std::string>{"position(r)@r.mi-position"});
  CHECK(plan.steps[1].toString() == "Lift(r)");

  p.goal.push_back({*peis::Term::parse("at(r, a)"), false});  // no link back to a
  const auto none = task::planTask(d, p);
  CHECK_FALSE(none.found);
  CHECK_THAT(task::formatText(none), Contains("no plan") && Contains("states searched"));

  CHECK_THAT(failure([] {
               task::Domain::fromYaml(
                   "domain: d\nactions:\n  - name: X\n    effects: [\"p(?q)\"]\n", "d.yaml");
             }),
             StartsWith("d.yaml:4:") && Contains("?q"));
  CHECK_THAT(
      failure([] { task::Domain::fromYaml("domain: d\nactions:\n  - name: X\n", "d.yaml"); }),
      StartsWith("d.yaml:3:") && Contains("no effects"));
  CHECK_THAT(failure([] {
               task::Domain::fromYaml(
                   "domain: d\nactions:\n  - {name: X, effects: [p], speed: 1}\n", "d.yaml");
             }),
             StartsWith("d.yaml:3:") && Contains("speed"));
  CHECK_THAT(failure([] {
               task::Domain::fromYaml(
                   "domain: d\nactions:\n  - {name: X, effects: [p], needs: [\"q(?z)\"]}\n",
                   "d.yaml");
             }),
             Contains("?z"));
  // on-failure: what a failure tells; its mistakes named.
  const auto withFailure = task::Domain::fromYaml(
      "domain: d\nactions:\n  - name: X\n    parameters: {r: robot}\n    effects: [p]\n"
      "    on-failure:\n      - {cause: too dark, effects: [\"not lit(?r)\"]}\n",
      "d.yaml");
  REQUIRE(withFailure.actions[0].failures.size() == 1);
  CHECK(withFailure.actions[0].failures[0].cause == "too dark");
  CHECK(withFailure.actions[0].failures[0].effects[0].toString() == "not lit(?r)");
  CHECK_THAT(failure([] {
               task::Domain::fromYaml(
                   "domain: d\nactions:\n  - name: X\n    effects: [p]\n"
                   "    on-failure:\n      - {cause: x, effects: [\"q(?z)\"]}\n",
                   "d.yaml");
             }),
             StartsWith("d.yaml:6:") && Contains("?z"));
  CHECK_THAT(failure([] {
               task::Domain::fromYaml(
                   "domain: d\nactions:\n  - name: X\n    effects: [p]\n"
                   "    on-failure:\n      - {effects: [q]}\n",
                   "d.yaml");
             }),
             StartsWith("d.yaml:6:") && Contains("cause"));
  CHECK_THAT(failure([] {
               task::Problem::fromYaml("problem: p\ndomain: d\ngoal: [\"q(?x)\"]\n", "p.yaml");
             }),
             StartsWith("p.yaml:3:") && Contains("variables"));
  CHECK_THAT(failure([] { task::Problem::fromYaml("problem: p\ndomain: d\n", "p.yaml"); }),
             StartsWith("p.yaml:1:") && Contains("goal is missing"));
  CHECK_THAT(failure([] { task::Problem::fromYaml("domain: d\ngoal: [p]\n", "p.yaml"); }),
             StartsWith("p.yaml:1:") && Contains("problem is missing"));
  CHECK_THAT(failure([] {
               task::Domain::fromYaml("domain: d\nactions:\n  - {effects: [p]}\n", "d.yaml");
             }),
             StartsWith("d.yaml:3:") && Contains("action name is missing"));
  CHECK_THAT(failure([&] {
               auto other = p;
               other.domain.assign(1, 'e');  // (= "e" trips a GCC 12 -Wrestrict false positive)
               task::planTask(d, other);
             }),
             Contains("for the domain 'e'"));
  CHECK_THAT(failure([&] {
               auto bad = p;
               bad.init.push_back(*peis::Term::parse("at(r)"));
               task::planTask(d, bad);
             }),
             Contains("'at' is used with"));
}
