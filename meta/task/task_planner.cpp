// The task planner: grounding by relaxed reachability, then A* over states
// (sets of facts) with the LM-cut heuristic on the delete relaxation.
#include <algorithm>
#include <chrono>
#include <functional>
#include <map>
#include <queue>
#include <set>
#include <unordered_map>

#include "peis/error.h"
#include "peis/meta/task.h"
#include "planner/lmcut.h"

namespace peis::meta::task {
namespace {

using Map = std::map<std::string, std::string>;

Term substitute(const Term& t, const Map& b) {
  Term out{t.functor, {}};
  for (const auto& a : t.args) {
    auto it = isVariable(a) ? b.find(a) : b.end();
    out.args.push_back(it == b.end() ? a : it->second);
  }
  return out;
}

std::string substituteText(const std::string& text, const Map& b) {
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    if (text[i] != '?') {
      out += text[i++];
      continue;
    }
    auto end = i + 1;
    while (end < text.size() && (std::isalnum(static_cast<unsigned char>(text[end])) ||
                                 text[end] == '-' || text[end] == '_')) {
      ++end;
    }
    auto it = b.find(text.substr(i, end - i));
    out += it == b.end() ? text.substr(i, end - i) : it->second;
    i = end;
  }
  return out;
}

struct GroundAction {
  std::string name;
  std::vector<std::string> arguments;
  std::vector<int> pre, negPre, add, del;
  double cost = 0;
  std::vector<std::string> needs;
};

// Facts are numbered as they are met.
struct Facts {
  std::unordered_map<std::string, int> ids;
  std::vector<std::string> names;
  int id(const std::string& text) {
    auto [it, inserted] = ids.emplace(text, static_cast<int>(names.size()));
    if (inserted) names.push_back(text);
    return it->second;
  }
  int find(const std::string& text) const {
    auto it = ids.find(text);
    return it == ids.end() ? -1 : it->second;
  }
};

using State = std::vector<std::uint64_t>;

struct StateHash {
  std::size_t operator()(const State& s) const {
    std::size_t h = 1469598103934665603ull;
    for (auto w : s) h = (h ^ w) * 1099511628211ull;
    return h;
  }
};

bool has(const State& s, int f) { return s[f >> 6] >> (f & 63) & 1; }
void put(State& s, int f) { s[f >> 6] |= std::uint64_t{1} << (f & 63); }
void drop(State& s, int f) { s[f >> 6] &= ~(std::uint64_t{1} << (f & 63)); }

}  // namespace

TaskPlan planTask(const Domain& domain, const Problem& problem, const TaskPlanOptions& options) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  TaskPlan plan;
  if (problem.domain != domain.name) {
    throw Error(ErrorCode::InvalidConfig, "the problem '" + problem.name + "' is for the domain '" +
                                              problem.domain + "', not '" + domain.name + "'");
  }
  // Objects and their types become facts; arities must agree everywhere.
  std::vector<Term> init = problem.init;
  std::map<std::string, std::vector<std::string>> ofType;
  std::vector<std::string> allObjects;
  for (const auto& [object, type] : problem.objects) {
    allObjects.push_back(object);
    if (!type.empty()) {
      init.push_back(Term{type, {object}});
      ofType[type].push_back(object);
    }
  }
  std::map<std::string, std::size_t> arity;
  auto checkArity = [&](const Term& t, const std::string& where) {
    if (t.functor == "!=") return;
    auto [it, inserted] = arity.emplace(t.functor, t.args.size());
    if (!inserted && it->second != t.args.size()) {
      throw Error(ErrorCode::InvalidConfig, where + ": '" + t.functor + "' is used with " +
                                                std::to_string(t.args.size()) + " and with " +
                                                std::to_string(it->second) + " arguments");
    }
  };
  for (const auto& t : init) checkArity(t, "problem " + problem.name);
  for (const auto& a : domain.actions) {
    for (const auto& l : a.preconditions) checkArity(l.atom, "action " + a.name);
    for (const auto& l : a.effects) checkArity(l.atom, "action " + a.name);
  }
  for (const auto& l : problem.goal) checkArity(l.atom, "the goal of " + problem.name);
  std::set<std::string> objectSet(allObjects.begin(), allObjects.end());
  for (const auto& t : init) {
    for (const auto& a : t.args) {
      if (!objectSet.count(a)) {
        throw Error(ErrorCode::InvalidConfig, "problem " + problem.name + ": the fact " +
                                                  t.toString() + " names '" + a +
                                                  "', which is not an object");
      }
    }
  }

  // Grounding: every action instance whose positive preconditions are
  // reachable in the delete relaxation.
  std::set<std::string> reachable;
  std::map<std::string, std::vector<std::vector<std::string>>> byFunctor;
  auto learn = [&](const Term& t) {
    if (reachable.insert(t.toString()).second) {
      byFunctor[t.functor].push_back(t.args);
      return true;
    }
    return false;
  };
  for (const auto& t : init) learn(t);
  std::map<std::string, int> seenInstance;
  std::vector<std::pair<const Action*, Map>> instances;
  bool changed = true;
  while (changed) {
    changed = false;
    for (const auto& a : domain.actions) {
      std::vector<const Literal*> positive;
      for (const auto& l : a.preconditions) {
        if (!l.negated && l.atom.functor != "!=") positive.push_back(&l);
      }
      Map b;
      std::vector<Map> found;
      std::function<void(std::size_t)> join = [&](std::size_t i) {
        if (i == positive.size()) {
          // Parameters no precondition bound: every object of their type.
          for (const auto& [var, type] : a.parameters) {
            if (b.count(var)) continue;
            for (const auto& o : type.empty() ? allObjects : ofType[type]) {
              b[var] = o;
              join(i);
            }
            b.erase(var);
            return;
          }
          for (const auto& [var, type] : a.parameters) {
            if (!type.empty() && !reachable.count(type + "(" + b[var] + ")")) return;
          }
          for (const auto& l : a.preconditions) {
            if (l.atom.functor == "!=" &&
                substitute(l.atom, b).args[0] == substitute(l.atom, b).args[1])
              return;
          }
          found.push_back(b);
          return;
        }
        const auto& atom = positive[i]->atom;
        auto it = byFunctor.find(atom.functor);
        if (it == byFunctor.end()) return;
        const auto& candidates = it->second;  // facts are learnt after the join
        for (const auto& args : candidates) {
          std::vector<std::string> added;
          bool ok = args.size() == atom.args.size();
          for (std::size_t k = 0; ok && k < args.size(); ++k) {
            const auto& x = atom.args[k];
            if (!isVariable(x)) {
              ok = x == args[k];
            } else if (auto bit = b.find(x); bit != b.end()) {
              ok = bit->second == args[k];
            } else {
              b[x] = args[k];
              added.push_back(x);
            }
          }
          if (ok) join(i + 1);
          for (const auto& x : added) b.erase(x);
        }
      };
      join(0);
      for (const auto& full : found) {
        std::string id = a.name;
        for (const auto& [var, value] : full) id += "|" + var + "=" + value;
        if (!seenInstance.emplace(id, 0).second) continue;
        instances.push_back({&a, full});
        changed = true;
        for (const auto& e : a.effects) {
          if (!e.negated) learn(substitute(e.atom, full));
        }
      }
    }
  }

  // Facts some action changes are fluents; the others are static.
  std::set<std::string> fluentNames;
  for (const auto& [a, b] : instances) {
    for (const auto& e : a->effects) fluentNames.insert(substitute(e.atom, b).toString());
  }
  Facts facts;
  for (const auto& name : fluentNames) facts.id(name);
  std::set<std::string> initSet;
  for (const auto& t : init) initSet.insert(t.toString());
  std::vector<GroundAction> actions;
  for (const auto& [a, b] : instances) {
    GroundAction g;
    g.name = a->name;
    for (const auto& [var, type] : a->parameters) g.arguments.push_back(b.at(var));
    g.cost = a->cost;
    bool possible = true;
    for (const auto& l : a->preconditions) {
      if (l.atom.functor == "!=") continue;
      const auto text = substitute(l.atom, b).toString();
      const int f = facts.find(text);
      if (f < 0) {  // static: must (not) hold initially
        possible = possible && (initSet.count(text) > 0) != l.negated;
      } else {
        (l.negated ? g.negPre : g.pre).push_back(f);
      }
    }
    if (!possible) continue;
    for (const auto& e : a->effects) {
      (e.negated ? g.del : g.add).push_back(facts.find(substitute(e.atom, b).toString()));
    }
    for (const auto& need : a->needs) g.needs.push_back(substituteText(need, b));
    actions.push_back(std::move(g));
  }
  plan.groundActions = static_cast<std::int64_t>(actions.size());

  const int words = (static_cast<int>(facts.names.size()) + 63) / 64 + 1;
  State initial(words, 0);
  for (const auto& t : init) {
    if (int f = facts.find(t.toString()); f >= 0) put(initial, f);
  }
  std::vector<int> goalPos, goalNeg;
  for (const auto& l : problem.goal) {
    const auto text = l.atom.toString();
    const int f = facts.find(text);
    if (f < 0) {
      if ((initSet.count(text) > 0) == l.negated) {
        plan.reason = "no plan: the goal " + l.toString() + " can never hold";
        plan.milliseconds = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        return plan;
      }
      continue;
    }
    (l.negated ? goalNeg : goalPos).push_back(f);
  }

  RelaxedTask relaxed;
  relaxed.facts = static_cast<int>(facts.names.size());
  std::vector<double> costs;
  for (const auto& a : actions) {
    relaxed.actions.push_back({a.pre, a.add});
    costs.push_back(a.cost);
  }
  LmCut lmcut(relaxed);
  std::vector<char> isTrue(facts.names.size());
  auto heuristic = [&](const State& s) {
    for (std::size_t f = 0; f < isTrue.size(); ++f) isTrue[f] = has(s, static_cast<int>(f));
    return lmcut.compute(costs, isTrue, goalPos);
  };
  auto isGoal = [&](const State& s) {
    for (int f : goalPos) {
      if (!has(s, f)) return false;
    }
    for (int f : goalNeg) {
      if (has(s, f)) return false;
    }
    return true;
  };

  // A*: ties go to the lower h (deeper), then to the earlier state.
  struct Node {
    State state;
    double g;
    int parent;
    int action;
    bool closed = false;
  };
  std::vector<Node> nodes;
  std::unordered_map<State, int, StateHash> index;
  using Entry = std::tuple<double, double, int>;  // f, h, node
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  const double h0 = heuristic(initial);
  nodes.push_back({initial, 0, -1, -1});
  index.emplace(initial, 0);
  if (h0 != kInfinity) open.push({h0, h0, 0});
  const bool timed = options.timeLimit.count() > 0;
  const auto deadline = start + options.timeLimit;
  int goalNode = -1;
  bool cut = false;
  while (!open.empty()) {
    const auto [f, h, n] = open.top();
    open.pop();
    if (f > nodes[n].g + h + 1e-9 || nodes[n].closed) continue;  // stale entry
    nodes[n].closed = true;
    if (isGoal(nodes[n].state)) {
      goalNode = n;
      break;
    }
    ++plan.statesExpanded;
    if ((options.stateLimit > 0 && plan.statesExpanded >= options.stateLimit) ||
        (timed && (plan.statesExpanded & 63) == 0 && Clock::now() >= deadline)) {
      cut = true;
      break;
    }
    for (int a = 0; a < static_cast<int>(actions.size()); ++a) {
      const auto& act = actions[a];
      const State& s = nodes[n].state;
      bool applicable = true;
      for (int p : act.pre) applicable = applicable && has(s, p);
      for (int p : act.negPre) applicable = applicable && !has(s, p);
      if (!applicable) continue;
      State next = s;
      for (int d : act.del) drop(next, d);
      for (int x : act.add) put(next, x);
      const double g = nodes[n].g + act.cost;
      auto it = index.find(next);
      if (it != index.end() && nodes[it->second].g <= g + 1e-12) continue;
      const double hn = heuristic(next);
      ++plan.statesGenerated;
      if (hn == kInfinity) continue;
      int id;
      if (it != index.end()) {
        id = it->second;
        nodes[id].g = g;
        nodes[id].parent = n;
        nodes[id].action = a;
        nodes[id].closed = false;  // reopened
      } else {
        id = static_cast<int>(nodes.size());
        nodes.push_back({std::move(next), g, n, a});
        index.emplace(nodes.back().state, id);
      }
      open.push({g + hn, hn, id});
    }
  }
  plan.milliseconds = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  if (goalNode < 0) {
    plan.reason = cut ? "no plan found before the limit" : "no plan: the goal is unreachable";
    return plan;
  }
  plan.found = true;
  plan.optimal = true;
  plan.cost = nodes[goalNode].g;
  for (int n = goalNode; nodes[n].parent >= 0; n = nodes[n].parent) {
    const auto& a = actions[nodes[n].action];
    plan.steps.push_back({a.name, a.arguments, a.cost, a.needs});
  }
  std::reverse(plan.steps.begin(), plan.steps.end());
  return plan;
}

}  // namespace peis::meta::task
