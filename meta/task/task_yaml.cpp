// Task domains and problems in YAML (docs/configuration.md, "Task planning").
#include "model/yaml_util.h"
#include "peis/meta/goals.h"
#include "peis/meta/task.h"

namespace peis::meta::task {
namespace {

Literal literal(std::string_view origin, const YAML::Node& node, const std::string& what,
                bool allowDisequality) {
  auto text = yaml::scalar(origin, node, what);
  Literal l;
  if (text.rfind("not ", 0) == 0) {
    l.negated = true;
    text = text.substr(4);
  }
  if (text.find("!=") != std::string::npos) {
    if (!allowDisequality || l.negated)
      yaml::fail(origin, node, what + " '" + text + "': a disequality is only a precondition");
    std::string problem;
    auto p = Precondition::parse(text, &problem);
    if (!p) yaml::fail(origin, node, what + " '" + text + "': " + problem);
    // Written as the atom "!=(left,right)".
    l.atom = Term{"!=", {p->left, p->right}};
    return l;
  }
  std::string problem;
  auto t = Term::parse(text, &problem);
  if (!t) yaml::fail(origin, node, what + " '" + text + "' is not an atom: " + problem);
  l.atom = *t;
  return l;
}

std::string variableName(std::string name) { return isVariable(name) ? name : "?" + name; }

Action action(std::string_view origin, const YAML::Node& node) {
  yaml::onlyKeys(origin, node,
                 {"name", "parameters", "preconditions", "effects", "cost", "needs", "on-failure"},
                 "an action");
  Action a;
  a.name = yaml::scalar(origin, yaml::field(origin, node, "name", "action name"), "action name");
  if (auto t = Term::parse(a.name); !t || !t->args.empty()) {
    yaml::fail(origin, node["name"], "action name '" + a.name + "' must be one word");
  }
  std::set<std::string> known;
  if (const auto params = node["parameters"]) {
    if (!params.IsMap())
      yaml::fail(origin, params, "parameters must be a mapping: {name: type, …}");
    for (const auto& item : params) {
      const auto var = variableName(yaml::scalar(origin, item.first, "parameter"));
      const auto type = item.second.IsNull() ? std::string()
                                             : yaml::scalar(origin, item.second, "parameter type");
      if (!known.insert(var).second)
        yaml::fail(origin, item.first, "parameter " + var + " is declared twice");
      a.parameters.push_back({var, type});
    }
  }
  std::set<std::string> bound = known;
  if (const auto list = node["preconditions"]) {
    for (const auto& item : yaml::sequence(origin, list, "preconditions")) {
      a.preconditions.push_back(literal(origin, item, "precondition", true));
      if (!a.preconditions.back().negated && a.preconditions.back().atom.functor != "!=") {
        for (const auto& v : a.preconditions.back().atom.variables()) bound.insert(v);
      }
    }
  }
  auto checkBound = [&](const Term& t, const YAML::Node& where) {
    for (const auto& v : t.variables()) {
      if (!bound.count(v)) {
        yaml::fail(origin, where,
                   "variable " + v + " of action " + a.name +
                       " is neither a parameter nor in a positive precondition");
      }
    }
  };
  std::size_t k = 0;
  if (const auto list = node["preconditions"]) {
    for (const auto& item : list) checkBound(a.preconditions[k++].atom, item);
  }
  if (const auto list = node["effects"]) {
    for (const auto& item : yaml::sequence(origin, list, "effects")) {
      a.effects.push_back(literal(origin, item, "effect", false));
      checkBound(a.effects.back().atom, item);
    }
  }
  if (a.effects.empty()) yaml::fail(origin, node, "action " + a.name + " has no effects");
  if (node["cost"]) a.cost = yaml::number(origin, node["cost"], "cost");
  if (const auto list = node["needs"]) {
    for (const auto& item : yaml::sequence(origin, list, "needs")) {
      const auto text = yaml::scalar(origin, item, "need");
      // Checked as a goal with the variables replaced by a sample value.
      std::string sample = text;
      for (auto at = sample.find('?'); at != std::string::npos; at = sample.find('?')) {
        auto end = at + 1;
        while (end < sample.size() && (std::isalnum(static_cast<unsigned char>(sample[end])) ||
                                       sample[end] == '-' || sample[end] == '_')) {
          ++end;
        }
        if (!bound.count(sample.substr(at, end - at))) {
          yaml::fail(origin, item,
                     "need '" + text + "' uses " + sample.substr(at, end - at) +
                         ", which is not a variable of the action");
        }
        sample.replace(at, end - at, "x");
      }
      try {
        Goals::fromArguments({sample});
      } catch (const Error& e) {
        yaml::fail(origin, item, "need '" + text + "' is not a goal: " + e.what());
      }
      a.needs.push_back(text);
    }
  }
  if (const auto list = node["on-failure"]) {
    for (const auto& item : yaml::sequence(origin, list, "on-failure")) {
      yaml::onlyKeys(origin, item, {"cause", "effects"}, "an on-failure entry");
      FailureEffect f;
      if (!item["cause"]) yaml::fail(origin, item, "on-failure: cause is missing");
      f.cause = yaml::scalar(origin, item["cause"], "cause");
      if (f.cause.empty()) yaml::fail(origin, item, "on-failure: cause is empty");
      if (!item["effects"]) yaml::fail(origin, item, "on-failure: effects is missing");
      for (const auto& e : yaml::sequence(origin, item["effects"], "effects")) {
        f.effects.push_back(literal(origin, e, "effect", false));
        checkBound(f.effects.back().atom, e);
      }
      a.failures.push_back(std::move(f));
    }
  }
  return a;
}

Domain parseDomain(std::string_view text, std::string_view origin) {
  const auto root = yaml::load(text, origin);
  yaml::onlyKeys(origin, root, {"domain", "actions"}, "the domain");
  Domain d;
  d.name = yaml::scalar(origin, yaml::field(origin, root, "domain", "domain"), "domain");
  if (!root["actions"]) yaml::fail(origin, root, "actions is missing");
  std::set<std::string> names;
  for (const auto& item : yaml::sequence(origin, root["actions"], "actions")) {
    d.actions.push_back(action(origin, item));
    if (!names.insert(d.actions.back().name).second) {
      yaml::fail(origin, item, "action " + d.actions.back().name + " is declared twice");
    }
  }
  return d;
}

Problem parseProblem(std::string_view text, std::string_view origin) {
  const auto root = yaml::load(text, origin);
  yaml::onlyKeys(origin, root, {"problem", "domain", "objects", "init", "goal"}, "the problem");
  Problem p;
  p.name = yaml::scalar(origin, yaml::field(origin, root, "problem", "problem"), "problem");
  p.domain = yaml::scalar(origin, yaml::field(origin, root, "domain", "domain"), "domain");
  if (const auto objects = root["objects"]) {
    if (!objects.IsMap())
      yaml::fail(origin, objects, "objects must be a mapping: {object: type, …}");
    for (const auto& item : objects) {
      const auto name = yaml::scalar(origin, item.first, "object");
      if (auto t = Term::parse(name); !t || !t->args.empty() || isVariable(name)) {
        yaml::fail(origin, item.first, "object '" + name + "' must be one word");
      }
      p.objects.push_back(
          {name, item.second.IsNull() ? "" : yaml::scalar(origin, item.second, "type")});
    }
  }
  if (const auto init = root["init"]) {
    for (const auto& item : yaml::sequence(origin, init, "init")) {
      p.init.push_back(yaml::term(origin, item, "fact"));
      if (!p.init.back().isGround()) yaml::fail(origin, item, "an initial fact has no variables");
    }
  }
  if (!root["goal"]) yaml::fail(origin, root, "goal is missing");
  for (const auto& item : yaml::sequence(origin, root["goal"], "goal")) {
    p.goal.push_back(literal(origin, item, "goal", false));
    if (!p.goal.back().atom.isGround()) yaml::fail(origin, item, "a goal has no variables");
  }
  return p;
}

}  // namespace

std::string Literal::toString() const { return (negated ? "not " : "") + atom.toString(); }

Domain Domain::fromYaml(std::string_view text, std::string_view origin) {
  return yaml::guarded(origin, [&] { return parseDomain(text, origin); });
}
Domain Domain::fromFile(const std::string& path) {
  return fromYaml(yaml::readFile(path, "domain file"), path);
}
Problem Problem::fromYaml(std::string_view text, std::string_view origin) {
  return yaml::guarded(origin, [&] { return parseProblem(text, origin); });
}
Problem Problem::fromFile(const std::string& path) {
  return fromYaml(yaml::readFile(path, "problem file"), path);
}

}  // namespace peis::meta::task
