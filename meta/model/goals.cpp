// Goals from a goal file or command-line arguments (docs/configuration.md,
// "Goals"), and instance selectors.
#include "peis/meta/goals.h"

#include "model/yaml_util.h"

namespace peis::meta {
namespace {

bool plainWord(std::string_view text) {
  auto t = Term::parse(text);
  return t && t->args.empty() && t->functor == text;
}

std::optional<InformationGoal> parseInformation(std::string_view text, std::string* problem) {
  InformationGoal g;
  const auto at = text.find('@');
  auto t = Term::parse(text.substr(0, at), problem);
  if (!t) return std::nullopt;
  if (!t->isGround()) {
    if (problem) *problem = "the information '" + t->toString() + "' must not have variables";
    return std::nullopt;
  }
  g.information = *t;
  if (at != std::string_view::npos) {
    const auto target = text.substr(at + 1);
    const auto dot = target.find('.');
    if (dot == std::string_view::npos || dot == 0 || dot + 1 == target.size()) {
      if (problem) *problem = "the consumer '" + std::string(target) + "' must be PEIS.KEY";
      return std::nullopt;
    }
    g.consumerPeis = std::string(target.substr(0, dot));
    g.consumerKey = std::string(target.substr(dot + 1));
    if (g.consumerKey.rfind("mi-", 0) != 0) {
      if (problem)
        *problem = "the consumer key '" + g.consumerKey + "' must be a meta input (mi-…)";
      return std::nullopt;
    }
  }
  return g;
}

std::optional<InstanceSelector> parseSelector(std::string_view text, std::string* problem,
                                              bool wholePeisAllowed) {
  auto s = InstanceSelector::parse(text, problem);
  if (!s) return std::nullopt;
  if (!wholePeisAllowed && (s->peis.empty() || s->functionality.empty())) {
    if (problem) *problem = "name a PEIS and a functionality: PEIS/COMPONENT/FUNCTIONALITY";
    return std::nullopt;
  }
  return s;
}

Goals parseGoals(std::string_view text, std::string_view origin) {
  const auto root = yaml::load(text, origin);
  Goals goals;
  if (!root.IsDefined() || root.IsNull()) return goals;
  yaml::onlyKeys(origin, root, {"goals", "avoid", "prefer"}, "the goal file");
  auto where = [&](const YAML::Node& n) {
    return std::string(origin) + ":" + std::to_string(n.Mark().line + 1);
  };
  if (const auto list = root["goals"]) {
    for (const auto& item : yaml::sequence(origin, list, "goals")) {
      std::string problem;
      if (item.IsScalar()) {
        auto g = parseInformation(item.as<std::string>(), &problem);
        if (!g) yaml::fail(origin, item, "goal '" + item.as<std::string>() + "': " + problem);
        g->origin = where(item);
        goals.information.push_back(*g);
        continue;
      }
      yaml::onlyKeys(origin, item, {"information", "consumer", "run"}, "a goal");
      if (item["run"]) {
        if (item["information"] || item["consumer"]) {
          yaml::fail(origin, item, "a goal is either 'run' or 'information', not both");
        }
        const auto text = yaml::scalar(origin, item["run"], "run");
        auto s = parseSelector(text, &problem, false);
        if (!s) yaml::fail(origin, item["run"], "run '" + text + "': " + problem);
        goals.run.push_back({*s, where(item)});
        continue;
      }
      auto text = yaml::scalar(origin, yaml::field(origin, item, "information", "information"),
                               "information");
      if (item["consumer"]) text += "@" + yaml::scalar(origin, item["consumer"], "consumer");
      auto g = parseInformation(text, &problem);
      if (!g) yaml::fail(origin, item, "goal '" + text + "': " + problem);
      g->origin = where(item);
      goals.information.push_back(*g);
    }
  }
  if (const auto list = root["avoid"]) {
    for (const auto& item : yaml::sequence(origin, list, "avoid")) {
      const auto text = yaml::scalar(origin, item, "avoid");
      if (plainWord(text)) {
        goals.constraints.avoidPeis.push_back(text);
        goals.constraints.avoidPeisOrigin.emplace(text, where(item));
        continue;
      }
      std::string problem;
      auto s = parseSelector(text, &problem, true);
      if (!s) yaml::fail(origin, item, "avoid '" + text + "': " + problem);
      goals.constraints.avoid.push_back(*s);
    }
  }
  if (const auto list = root["prefer"]) {
    for (const auto& item : yaml::sequence(origin, list, "prefer")) {
      const auto text = yaml::scalar(origin, item, "prefer");
      std::string problem;
      auto s = parseSelector(text, &problem, true);
      if (!s) yaml::fail(origin, item, "prefer '" + text + "': " + problem);
      goals.constraints.prefer.push_back(*s);
    }
  }
  return goals;
}

}  // namespace

std::string InstanceSelector::toString() const {
  std::string text = peis.empty() ? "*" : peis;
  if (!component.empty() || !functionality.empty()) {
    text += "/" + (component.empty() ? std::string("*") : component);
    if (!functionality.empty()) text += "/" + functionality;
  }
  if (!binding.empty()) {
    text += "{";
    bool first = true;
    for (const auto& [var, value] : binding) {
      text += (first ? "" : ",") + var + "=" + value;
      first = false;
    }
    text += "}";
  }
  return text;
}

std::optional<InstanceSelector> InstanceSelector::parse(std::string_view text,
                                                        std::string* problem) {
  auto bad = [&](std::string why) {
    if (problem) *problem = std::move(why);
    return std::nullopt;
  };
  InstanceSelector s;
  const auto brace = text.find('{');
  auto path = text.substr(0, brace);
  if (brace != std::string_view::npos) {
    if (text.back() != '}') return bad("the binding must end with '}'");
    auto inside = text.substr(brace + 1, text.size() - brace - 2);
    while (!inside.empty()) {
      const auto comma = inside.find(',');
      const auto item = inside.substr(0, comma);
      const auto eq = item.find('=');
      if (eq == std::string_view::npos) return bad("a binding is written ?var=value");
      std::string var(item.substr(0, eq)), value(item.substr(eq + 1));
      if (!isVariable(var)) var = "?" + var;
      if (!plainWord(var.substr(1)) || !plainWord(value)) {
        return bad("the binding '" + std::string(item) + "' is not ?var=value");
      }
      s.binding[var] = value;
      if (comma == std::string_view::npos) break;
      inside = inside.substr(comma + 1);
    }
  }
  std::string* fields[] = {&s.peis, &s.component, &s.functionality};
  for (int i = 0; i < 3; ++i) {
    const auto slash = path.find('/');
    std::string part(path.substr(0, slash));
    if (part != "*" && !part.empty()) {
      if (!plainWord(part)) return bad("'" + part + "' is not a plain name");
      *fields[i] = part;
    }
    if (slash == std::string_view::npos) break;
    if (i == 2) return bad("at most PEIS/COMPONENT/FUNCTIONALITY");
    path = path.substr(slash + 1);
  }
  if (s.peis.empty() && s.component.empty() && s.functionality.empty() && s.binding.empty()) {
    return bad("the selector selects everything");
  }
  return s;
}

std::string InformationGoal::toString() const {
  auto text = information.toString();
  if (!consumerPeis.empty()) text += "@" + consumerPeis + "." + consumerKey;
  return text;
}

Goals Goals::fromYaml(std::string_view text, std::string_view origin) {
  return yaml::guarded(origin, [&] { return parseGoals(text, origin); });
}

Goals Goals::fromFile(const std::string& path) {
  return fromYaml(yaml::readFile(path, "goal file"), path);
}

Goals Goals::fromArguments(const std::vector<std::string>& arguments) {
  Goals goals;
  for (std::size_t i = 0; i < arguments.size(); ++i) {
    const auto& arg = arguments[i];
    const auto origin = "argument " + std::to_string(i + 1);
    std::string problem;
    auto fail = [&] {
      throw Error(ErrorCode::InvalidArgument, origin + " '" + arg + "': " + problem);
    };
    auto after = [&](std::string_view prefix) -> std::optional<std::string> {
      if (arg.rfind(prefix, 0) == 0) return arg.substr(prefix.size());
      return std::nullopt;
    };
    if (auto rest = after("run:")) {
      auto s = parseSelector(*rest, &problem, false);
      if (!s) fail();
      goals.run.push_back({*s, origin});
    } else if (auto rest = after("avoid:")) {
      if (plainWord(*rest)) {
        goals.constraints.avoidPeis.push_back(*rest);
        goals.constraints.avoidPeisOrigin.emplace(*rest, origin);
      } else {
        auto s = parseSelector(*rest, &problem, true);
        if (!s) fail();
        goals.constraints.avoid.push_back(*s);
      }
    } else if (auto rest = after("prefer:")) {
      auto s = parseSelector(*rest, &problem, true);
      if (!s) fail();
      goals.constraints.prefer.push_back(*s);
    } else {
      auto g = parseInformation(arg, &problem);
      if (!g) fail();
      g->origin = origin;
      goals.information.push_back(*g);
    }
  }
  return goals;
}

std::string Goals::toYaml() const {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "goals" << YAML::Value << YAML::BeginSeq;
  for (const auto& g : information) out << g.toString();
  for (const auto& r : run) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "run" << YAML::Value
        << r.instance.toString() << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!constraints.avoidPeis.empty() || !constraints.avoid.empty()) {
    out << YAML::Key << "avoid" << YAML::Value << YAML::BeginSeq;
    for (const auto& p : constraints.avoidPeis) out << p;
    for (const auto& s : constraints.avoid) out << s.toString();
    out << YAML::EndSeq;
  }
  if (!constraints.prefer.empty()) {
    out << YAML::Key << "prefer" << YAML::Value << YAML::BeginSeq;
    for (const auto& s : constraints.prefer) out << s.toString();
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace peis::meta
