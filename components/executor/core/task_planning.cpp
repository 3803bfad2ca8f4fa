// Task planning for the executor; see task_planning.h.
#include "task_planning.h"

#include <algorithm>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>

namespace peis::executor {
namespace {

using meta::task::Action;
using meta::task::Literal;
using Binding = std::map<std::string, std::string>;

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\n");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\n");
  return std::string(s.substr(b, e - b + 1));
}

Term ground(const Term& t, const Binding& b) {
  Term out{t.functor, {}};
  for (const auto& a : t.args) {
    const auto it = b.find(a);
    out.args.push_back(it == b.end() ? a : it->second);
  }
  return out;
}

// Binds the variables of `preconditions` not bound yet to facts of `state`,
// depth first; calls `found` with the first complete binding that also meets
// the disequalities and negative preconditions.
bool bindRest(const std::vector<Literal>& preconditions, std::size_t i, Binding& b,
              const std::set<Term>& state) {
  if (i == preconditions.size()) {
    for (const auto& p : preconditions) {
      const Term g = ground(p.atom, b);
      if (g.functor == "!=") {
        if (g.args.size() == 2 && g.args[0] == g.args[1]) return false;
      } else if (p.negated && state.count(g)) {
        return false;
      }
    }
    return true;
  }
  const Literal& p = preconditions[i];
  if (p.negated || p.atom.functor == "!=") return bindRest(preconditions, i + 1, b, state);
  const Term partial = ground(p.atom, b);
  for (const auto& fact : state) {
    if (fact.functor != partial.functor || fact.args.size() != partial.args.size()) continue;
    Binding tried = b;
    bool fits = true;
    for (std::size_t k = 0; k < fact.args.size() && fits; ++k) {
      const auto& want = partial.args[k];
      if (!isVariable(want)) {
        fits = want == fact.args[k];
      } else if (const auto it = tried.find(want); it != tried.end()) {
        fits = it->second == fact.args[k];
      } else {
        tried[want] = fact.args[k];
      }
    }
    if (fits && bindRest(preconditions, i + 1, tried, state)) {
      b = tried;
      return true;
    }
  }
  return false;
}

// The effects the failed step's action declares for its cause, applied to
// `state` (its parameters bound to the step's arguments, its other
// variables to facts of the state as far as they can be).
void applyFailure(const meta::task::Domain& domain, const FailedStep& failed,
                  const std::set<Term>& types, std::set<Term>& state) {
  const auto action = std::find_if(domain.actions.begin(), domain.actions.end(),
                                   [&](const Action& a) { return a.name == failed.step.action; });
  if (action == domain.actions.end() || action->parameters.size() != failed.step.args.size())
    return;
  Binding b;
  for (std::size_t i = 0; i < failed.step.args.size(); ++i)
    b[action->parameters[i].first] = failed.step.args[i];
  std::set<Term> known = state;
  known.insert(types.begin(), types.end());
  Binding full = b;
  if (bindRest(action->preconditions, 0, full, known)) b = full;
  for (const auto& f : action->failures) {
    if (failed.cause.find(f.cause) == std::string::npos) continue;
    for (const auto& e : f.effects) {
      const Term g = ground(e.atom, b);
      if (!g.isGround()) continue;
      if (e.negated)
        state.erase(g);
      else
        state.insert(g);
    }
  }
}

}  // namespace

std::vector<Literal> parseTask(std::string_view text) {
  std::vector<std::string> parts;
  std::string current;
  int depth = 0;
  for (const char c : text) {
    if (c == '(') ++depth;
    if (c == ')') --depth;
    if (c == ',' && depth == 0) {
      parts.push_back(current);
      current.clear();
    } else {
      current += c;
    }
  }
  parts.push_back(current);
  std::vector<Literal> goal;
  for (const auto& raw : parts) {
    std::string part = trim(raw);
    Literal l;
    if (part.rfind("not ", 0) == 0) {
      l.negated = true;
      part = trim(part.substr(4));
    }
    std::string problem;
    const auto term = Term::parse(part, &problem);
    if (part.empty() || !term)
      throw std::invalid_argument("task literal '" + trim(raw) + "' is not an atom" +
                                  (problem.empty() ? std::string() : ": " + problem));
    if (!term->isGround())
      throw std::invalid_argument("task literal '" + part +
                                  "' has a variable: a task names objects");
    l.atom = *term;
    goal.push_back(std::move(l));
  }
  return goal;
}

std::vector<Term> stateAfter(const meta::task::Domain& domain, const meta::task::Problem& problem,
                             const std::vector<PlanStep>& done,
                             const std::vector<FailedStep>& failures) {
  std::set<Term> state(problem.init.begin(), problem.init.end());
  std::set<Term> types;  // `robot(pippi)` for the objects: preconditions may name them
  for (const auto& [object, type] : problem.objects) types.insert(Term{type, {object}});
  std::size_t index = 0;
  auto failuresAt = [&](std::size_t at) {
    for (const auto& f : failures)
      if (f.after == at || (at == done.size() && f.after > at))
        applyFailure(domain, f, types, state);
  };
  for (const auto& step : done) {
    failuresAt(index++);
    const auto action = std::find_if(domain.actions.begin(), domain.actions.end(),
                                     [&](const Action& a) { return a.name == step.action; });
    if (action == domain.actions.end())
      throw std::invalid_argument("step " + step.toString() + ": no action " + step.action +
                                  " in domain " + domain.name);
    if (action->parameters.size() != step.args.size())
      throw std::invalid_argument("step " + step.toString() + ": " + step.action + " takes " +
                                  std::to_string(action->parameters.size()) + " arguments");
    Binding b;
    for (std::size_t i = 0; i < step.args.size(); ++i)
      b[action->parameters[i].first] = step.args[i];
    std::set<Term> known = state;
    known.insert(types.begin(), types.end());
    if (!bindRest(action->preconditions, 0, b, known))
      throw std::invalid_argument("step " + step.toString() +
                                  " cannot be applied: its preconditions do not hold");
    for (const auto& e : action->effects) {
      if (e.negated) state.erase(ground(e.atom, b));
    }
    for (const auto& e : action->effects) {
      if (!e.negated) state.insert(ground(e.atom, b));
    }
  }
  failuresAt(done.size());
  // The problem's facts that still hold in their order, then the new ones
  // (the planner breaks ties by order: the same state plans the same way).
  std::vector<Term> out;
  for (const auto& t : problem.init) {
    if (state.erase(t)) out.push_back(t);
  }
  out.insert(out.end(), state.begin(), state.end());
  return out;
}

PlannedTask planFrom(const meta::task::Domain& domain, const meta::task::Problem& problem,
                     const std::vector<Literal>& goal, const std::vector<PlanStep>& done,
                     const std::vector<FailedStep>& failures) {
  meta::task::Problem now = problem;
  now.init = stateAfter(domain, problem, done, failures);
  now.goal = goal;
  meta::task::TaskPlanOptions options;
  options.timeLimit = std::chrono::seconds(5);
  const auto plan = meta::task::planTask(domain, now, options);
  PlannedTask result;
  result.found = plan.found;
  if (!plan.found) {
    result.text = plan.reason;
    return result;
  }
  for (const auto& s : plan.steps) {
    result.steps.push_back(PlanStep{s.action, s.arguments, s.needs});
    result.text += (result.text.empty() ? "" : "; ") + s.toString();
  }
  if (result.steps.empty()) result.text = "nothing to do: the goal holds";
  return result;
}

}  // namespace peis::executor
