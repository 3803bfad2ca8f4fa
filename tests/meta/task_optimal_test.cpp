// The task planner is optimal: on random small STRIPS problems (parameters,
// negative preconditions, disequalities, delete effects, costs) its plan
// cost equals that of an exhaustive uniform-cost search over the ground
// states, made here without the planner's grounding or heuristic, and every
// plan it returns is checked step by step.
#include <catch2/catch.hpp>
#include <cstdint>
#include <map>
#include <optional>
#include <queue>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "peis/meta/task.h"

using namespace peis::meta;

namespace {

// A literal of the generated domain: predicate, arguments (`?x` or objects).
struct Lit {
  int predicate = 0;
  std::vector<std::string> args;
  bool negated = false;
  bool disequality = false;  // args[0] != args[1]
};

struct GenAction {
  std::string name;
  std::vector<std::string> parameters;  // "?a", …
  std::vector<Lit> preconditions, effects;
  int cost = 1;
};

struct Generated {
  std::vector<int> arity;  // per predicate p0, p1, …
  std::vector<std::string> objects;
  std::vector<GenAction> actions;
  std::vector<Lit> init, goal;  // ground
};

std::string atomText(const Lit& l) {
  std::string text = "p" + std::to_string(l.predicate);
  if (!l.args.empty()) {
    text += "(";
    for (std::size_t i = 0; i < l.args.size(); ++i) text += (i ? ", " : "") + l.args[i];
    text += ")";
  }
  return text;
}

std::string literalText(const Lit& l) {
  if (l.disequality) return l.args[0] + " != " + l.args[1];
  return (l.negated ? "not " : "") + atomText(l);
}

Generated generate(std::mt19937& rng) {
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  Generated g;
  const int objects = pick(2, 3);
  for (int i = 0; i < objects; ++i) g.objects.push_back("o" + std::to_string(i));
  const int predicates = pick(2, 4);
  for (int i = 0; i < predicates; ++i) g.arity.push_back(pick(0, 2));
  auto literal = [&](const std::vector<std::string>& terms) {
    Lit l;
    l.predicate = pick(0, predicates - 1);
    for (int i = 0; i < g.arity[l.predicate]; ++i)
      l.args.push_back(terms[pick(0, static_cast<int>(terms.size()) - 1)]);
    return l;
  };
  const int actions = pick(2, 5);
  for (int a = 0; a < actions; ++a) {
    GenAction act;
    act.name = "A" + std::to_string(a);
    const int params = pick(0, 2);
    for (int i = 0; i < params; ++i) act.parameters.push_back("?v" + std::to_string(i));
    // Arguments: the parameters, and now and then an object.
    std::vector<std::string> terms = act.parameters;
    terms.push_back(g.objects[pick(0, objects - 1)]);
    for (int i = pick(0, 3); i > 0; --i) {
      auto l = literal(terms);
      l.negated = pick(0, 3) == 0;
      act.preconditions.push_back(l);
    }
    if (params == 2 && pick(0, 2) == 0)
      act.preconditions.push_back({0, {"?v0", "?v1"}, false, true});
    // Effects: adds and deletes, never both on one predicate (what an action
    // that adds and deletes one atom means is not what this test is about).
    std::map<int, bool> polarity;
    for (int i = pick(1, 3); i > 0; --i) {
      auto l = literal(terms);
      const bool negated = pick(0, 2) == 0;
      auto [it, fresh] = polarity.emplace(l.predicate, negated);
      if (!fresh && it->second != negated) continue;
      l.negated = negated;
      act.effects.push_back(l);
    }
    act.cost = pick(1, 5);
    g.actions.push_back(act);
  }
  auto ground = [&] {
    Lit l;
    l.predicate = pick(0, predicates - 1);
    for (int i = 0; i < g.arity[l.predicate]; ++i)
      l.args.push_back(g.objects[pick(0, objects - 1)]);
    return l;
  };
  for (int i = pick(0, 4); i > 0; --i) g.init.push_back(ground());
  for (int i = pick(1, 3); i > 0; --i) {
    auto l = ground();
    l.negated = pick(0, 4) == 0;
    g.goal.push_back(l);
  }
  return g;
}

std::string domainYaml(const Generated& g) {
  std::ostringstream out;
  out << "domain: random\nactions:\n";
  for (const auto& a : g.actions) {
    out << "  - name: " << a.name << "\n    parameters: {";
    for (std::size_t i = 0; i < a.parameters.size(); ++i)
      out << (i ? ", " : "") << a.parameters[i].substr(1) << ": thing";
    out << "}\n    preconditions: [";
    for (std::size_t i = 0; i < a.preconditions.size(); ++i)
      out << (i ? ", " : "") << '"' << literalText(a.preconditions[i]) << '"';
    out << "]\n    effects: [";
    for (std::size_t i = 0; i < a.effects.size(); ++i)
      out << (i ? ", " : "") << '"' << literalText(a.effects[i]) << '"';
    out << "]\n    cost: " << a.cost << "\n";
  }
  return out.str();
}

std::string problemYaml(const Generated& g) {
  std::ostringstream out;
  out << "problem: p\ndomain: random\nobjects: {";
  for (std::size_t i = 0; i < g.objects.size(); ++i)
    out << (i ? ", " : "") << g.objects[i] << ": thing";
  out << "}\ninit: [";
  for (std::size_t i = 0; i < g.init.size(); ++i)
    out << (i ? ", " : "") << '"' << atomText(g.init[i]) << '"';
  out << "]\ngoal: [";
  for (std::size_t i = 0; i < g.goal.size(); ++i)
    out << (i ? ", " : "") << '"' << literalText(g.goal[i]) << '"';
  out << "]\n";
  return out.str();
}

// The reference: every ground atom a bit, every assignment of the
// parameters an action, Dijkstra over the reachable states.
struct Reference {
  const Generated& g;
  std::map<std::string, int> bit;  // ground atom text -> bit

  explicit Reference(const Generated& generated) : g(generated) {
    for (std::size_t p = 0; p < g.arity.size(); ++p) {
      std::vector<std::vector<std::string>> tuples{{}};
      for (int i = 0; i < g.arity[p]; ++i) {
        std::vector<std::vector<std::string>> longer;
        for (const auto& t : tuples)
          for (const auto& o : g.objects) {
            auto u = t;
            u.push_back(o);
            longer.push_back(u);
          }
        tuples = longer;
      }
      for (const auto& t : tuples) {
        const int next = static_cast<int>(bit.size());
        bit[atomText({static_cast<int>(p), t, false, false})] = next;
      }
    }
    REQUIRE(bit.size() <= 64);
  }

  Lit bound(const Lit& l, const std::map<std::string, std::string>& values) const {
    Lit out = l;
    for (auto& a : out.args)
      if (a.front() == '?') a = values.at(a);
    return out;
  }
  std::uint64_t mask(const Lit& ground) const {
    return std::uint64_t{1} << bit.at(atomText(ground));
  }

  struct Ground {
    std::string text;  // `A0(o1, o0)`
    std::uint64_t pos = 0, neg = 0, add = 0, del = 0;
    int cost = 0;
  };
  std::vector<Ground> groundActions() const {
    std::vector<Ground> out;
    for (const auto& a : g.actions) {
      std::vector<std::map<std::string, std::string>> assignments{{}};
      for (const auto& p : a.parameters) {
        std::vector<std::map<std::string, std::string>> more;
        for (const auto& m : assignments)
          for (const auto& o : g.objects) {
            auto n = m;
            n[p] = o;
            more.push_back(n);
          }
        assignments = more;
      }
      for (const auto& values : assignments) {
        Ground ga;
        ga.cost = a.cost;
        ga.text = a.name + "(";
        for (std::size_t i = 0; i < a.parameters.size(); ++i)
          ga.text += (i ? ", " : "") + values.at(a.parameters[i]);
        ga.text += ")";
        bool possible = true;
        for (const auto& l : a.preconditions) {
          const auto b = bound(l, values);
          if (l.disequality) {
            possible = possible && b.args[0] != b.args[1];
          } else {
            (l.negated ? ga.neg : ga.pos) |= mask(b);
          }
        }
        if (!possible || (ga.pos & ga.neg)) continue;
        for (const auto& l : a.effects) (l.negated ? ga.del : ga.add) |= mask(bound(l, values));
        out.push_back(ga);
      }
    }
    return out;
  }

  std::uint64_t initial() const {
    std::uint64_t s = 0;
    for (const auto& l : g.init) s |= mask(l);
    return s;
  }
  bool reached(std::uint64_t s) const {
    for (const auto& l : g.goal)
      if (((s & mask(l)) != 0) == l.negated) return false;
    return true;
  }
  static std::uint64_t apply(const Ground& a, std::uint64_t s) { return (s & ~a.del) | a.add; }
  static bool applicable(const Ground& a, std::uint64_t s) {
    return (s & a.pos) == a.pos && (s & a.neg) == 0;
  }

  // The cheapest plan's cost, or nothing when the goal is unreachable.
  std::optional<int> optimum() const {
    const auto actions = groundActions();
    std::map<std::uint64_t, int> best;
    using Entry = std::pair<int, std::uint64_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
    open.push({0, initial()});
    best[initial()] = 0;
    while (!open.empty()) {
      const auto [cost, s] = open.top();
      open.pop();
      if (cost > best[s]) continue;
      if (reached(s)) return cost;
      for (const auto& a : actions) {
        if (!applicable(a, s)) continue;
        const auto next = apply(a, s);
        const int c = cost + a.cost;
        auto it = best.find(next);
        if (it == best.end() || c < it->second) {
          best[next] = c;
          open.push({c, next});
        }
      }
    }
    return std::nullopt;
  }

  // Runs the planner's plan: each step applicable, the goal reached, the cost right.
  std::string check(const task::TaskPlan& plan) const {
    const auto actions = groundActions();
    auto s = initial();
    double cost = 0;
    for (const auto& step : plan.steps) {
      const auto text = step.toString();
      const Ground* found = nullptr;
      for (const auto& a : actions)
        if (a.text == text) found = &a;
      if (!found) return "step " + text + " is not a ground action";
      if (!applicable(*found, s)) return "step " + text + " is not applicable";
      s = apply(*found, s);
      cost += found->cost;
    }
    if (!reached(s)) return "the plan does not reach the goal";
    if (cost != plan.cost) return "the plan's steps cost " + std::to_string(cost);
    return "";
  }
};

}  // namespace

TEST_CASE("the task planner is optimal on 3,000 random small problems (exhaustive search)",
          "[unit][task]") {
  std::mt19937 rng(20261125);
  int solved = 0, unreachable = 0;
  for (int run = 0; run < 3000; ++run) {
    const auto g = generate(rng);
    const auto domainText = domainYaml(g), problemText = problemYaml(g);
    INFO("run " << run << "\n" << domainText << problemText);
    const auto domain = task::Domain::fromYaml(domainText, "random.domain.yaml");
    const auto problem = task::Problem::fromYaml(problemText, "random.problem.yaml");
    const auto plan = task::planTask(domain, problem);
    const Reference reference(g);
    const auto optimum = reference.optimum();
    INFO(task::formatText(plan));
    REQUIRE(plan.found == optimum.has_value());
    if (!optimum) {
      CHECK(plan.reason.rfind("no plan", 0) == 0);
      ++unreachable;
      continue;
    }
    CHECK(plan.optimal);
    REQUIRE(plan.cost == *optimum);
    REQUIRE(reference.check(plan) == "");
    ++solved;
  }
  // Both outcomes occur often enough to matter.
  CHECK(solved > 500);
  CHECK(unreachable > 100);
}
