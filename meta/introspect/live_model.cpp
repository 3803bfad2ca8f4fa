// LiveModel: the ecology as introspection sees it, and its conversions
// (planner model, text, JSON, YAML).
#include "introspect/live_model.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <set>

#include "model/yaml_util.h"
#include "peis/conventions.h"
#include "peis/error.h"
#include "peis/key.h"
#include "planner/json.h"

namespace peis::meta {
namespace {

bool plannableName(const std::string& name) {
  const auto term = Term::parse(name);
  return term && term->args.empty() && term->functor == name;
}

std::string plannerName(const LivePeis& p) {
  return plannableName(p.name) ? p.name : "peis-" + std::to_string(p.id);
}

std::string lastLine(const std::string& text) {
  auto end = text.find_last_not_of('\n');
  if (end == std::string::npos) return "";
  const auto start = text.rfind('\n', end);
  return text.substr(start == std::string::npos ? 0 : start + 1,
                     end - (start == std::string::npos ? 0 : start + 1) + 1);
}

void emitMap(YAML::Emitter& out, const std::map<std::string, std::string>& map) {
  out << YAML::BeginMap;
  for (const auto& [k, v] : map) out << YAML::Key << k << YAML::Value << v;
  out << YAML::EndMap;
}

std::map<std::string, std::string> readMap(std::string_view origin, const YAML::Node& node,
                                           const std::string& what) {
  std::map<std::string, std::string> map;
  if (!node) return map;
  if (!node.IsMap()) yaml::fail(origin, node, what + " must be a mapping");
  for (const auto& item : node) {
    map[item.first.as<std::string>()] = item.second.IsNull() ? "" : item.second.as<std::string>();
  }
  return map;
}

std::string text(std::string_view origin, const YAML::Node& node, const std::string& what) {
  if (!node || node.IsNull()) return "";
  return yaml::scalar(origin, node, what);
}

}  // namespace

static LiveModel parseLiveModel(const YAML::Node& root, std::string_view origin);

std::optional<Term> factOfKey(std::string_view key) {
  if (key.substr(0, conventions::kFactPrefix.size()) != conventions::kFactPrefix) return {};
  const auto parts = splitKey(key.substr(conventions::kFactPrefix.size()));
  if (parts.empty() || parts[0].empty()) return {};
  std::string termText(parts[0]);
  if (parts.size() > 1) {
    termText += "(";
    for (std::size_t i = 1; i < parts.size(); ++i)
      termText += (i > 1 ? "," : "") + std::string(parts[i]);
    termText += ")";
  }
  auto term = Term::parse(termText);
  if (!term || !term->isGround()) return {};
  return term;
}

const LivePeis* LiveModel::find(int id) const {
  for (const auto& p : peis)
    if (p.id == id) return &p;
  return nullptr;
}

const LivePeis* LiveModel::findByName(std::string_view name) const {
  const LivePeis* dead = nullptr;
  for (const auto& p : peis) {
    if (p.name != name) continue;
    if (p.alive) return &p;
    dead = &p;
  }
  return dead;
}

std::optional<LiveModel::Launchable> LiveModel::launchable(std::string_view peisName) const {
  for (const auto& p : peis) {
    if (!p.alive) continue;
    for (const auto& [component, entry] : p.launches) {
      if (entry.peisName != peisName || !entry.descriptor) continue;
      if (entry.currState == conventions::kLaunchFailed ||
          entry.currState == conventions::kLaunchRestarting)
        continue;
      return Launchable{&p, component, &entry};
    }
  }
  return std::nullopt;
}

std::string LiveModel::canonicalTarget(const std::string& data) const {
  try {
    const auto name = parseFullName(data);
    if (name.ownerId()) return std::to_string(*name.ownerId()) + "." + name.key;
    if (const auto* p = findByName(name.owner)) return std::to_string(p->id) + "." + name.key;
  } catch (const Error&) {
  }
  return data;
}

Model LiveModel::toModel(const LinkCosts& costs,
                         const std::vector<LinkCostOverride>& overrides) const {
  Model model;
  model.linkCosts = costs;
  model.linkOverrides = overrides;
  std::set<std::string> aliveNames;
  std::map<std::string, std::int64_t> latestGone;  // name -> the last life's incarnation
  for (const auto& p : peis) {
    if (p.alive) {
      aliveNames.insert(plannerName(p));
    } else {
      auto& latest = latestGone[plannerName(p)];
      latest = std::max(latest, p.incarnation);
    }
  }
  std::set<std::string> used;
  for (const auto& p : peis) {
    const auto name = plannerName(p);
    if (!p.alive && aliveNames.count(name)) continue;            // restarted under a new id
    if (!p.alive && p.incarnation < latestGone[name]) continue;  // an earlier life
    PeisInfo info;
    info.id = p.id;
    info.name = used.count(name) ? name + "-" + std::to_string(p.id) : name;
    used.insert(info.name);
    info.alive = p.alive;
    info.radio = p.radio;
    if (p.descriptor) info.components.push_back(*p.descriptor);
    model.peis.push_back(std::move(info));
  }
  // Components a launcher can start: alive for the planner, id 0 until they run.
  std::set<std::string> launchNames;
  for (const auto& p : peis) {
    if (!p.alive) continue;
    for (const auto& [component, entry] : p.launches) {
      const auto& name = entry.peisName;
      if (!plannableName(name) || aliveNames.count(name) || launchNames.count(name)) continue;
      const auto where = launchable(name);
      if (!where || where->entry != &entry) continue;
      launchNames.insert(name);
      PeisInfo info;
      info.name = name;
      info.components.push_back(*entry.descriptor);
      // It replaces a gone PEIS of that name (an earlier run).
      std::erase_if(model.peis, [&](const PeisInfo& i) { return i.name == name; });
      model.peis.push_back(std::move(info));
    }
  }
  std::set<Term> seen;
  for (const auto& p : peis) {
    if (!p.alive) continue;
    for (const auto& f : p.facts) {
      auto atom = Term::parse(f);
      if (!atom || !seen.insert(*atom).second) continue;
      model.facts.push_back(Fact{*atom, plannerName(p)});
    }
  }
  return model;
}

std::string LiveModel::toText() const {
  std::string out;
  for (const auto& p : peis) {
    out += "PEIS " + std::to_string(p.id) + " '" + p.name + "'";
    if (!p.alive) out += " (gone)";
    if (p.radio) out += " (tiny node)";
    if (p.configurator) out += " (configurator)";
    out += "\n";
    if (!p.component.empty() || !p.status.empty()) {
      out += "  component " + (p.component.empty() ? std::string("?") : p.component) + ": " +
             (p.status.empty() ? std::string("no status") : p.status);
      if (!p.causes.empty()) out += " (" + p.causes + ")";
      out += "\n";
    }
    if (p.descriptor) {
      for (const auto& f : p.descriptor->functionalities) {
        out += "  functionality " + f.name;
        if (!f.inputs.empty()) out += "  in: " + formatPorts(f.inputs);
        if (!f.outputs.empty()) out += "  out: " + formatPorts(f.outputs);
        if (!f.preconditions.empty()) {
          out += "  if:";
          for (const auto& c : f.preconditions) out += " " + c;
        }
        if (!f.activation.empty()) out += "  switch: " + f.activation;
        char cost[32];
        std::snprintf(cost, sizeof cost, "%g", f.cost);
        out += std::string("  cost ") + cost + "\n";
      }
    } else if (!p.descriptorProblem.empty()) {
      out += "  descriptor not usable: " + p.descriptorProblem + "\n";
    }
    for (const auto& [key, target] : p.links)
      out += "  link " + key + " <- " + (target.empty() ? std::string("(nowhere)") : target) + "\n";
    for (const auto& [name, a] : p.actuators)
      out += "  actuator " + name + ": reqState " + (a.reqState.empty() ? "-" : a.reqState) +
             ", currState " + (a.currState.empty() ? "-" : a.currState) + ", status " +
             (a.status.empty() ? "-" : a.status) + "\n";
    for (const auto& f : p.facts) out += "  fact " + f + "\n";
    for (const auto& [key, goals] : p.goals) {
      std::string oneLine;
      for (char c : goals) oneLine += c == '\n' ? ' ' : c;
      while (!oneLine.empty() && oneLine.back() == ' ') oneLine.pop_back();
      out += "  goals " + key + ": " + (oneLine.empty() ? std::string("(none)") : oneLine) + "\n";
    }
    if (!lastLine(p.lock).empty()) out += "  config.lock: " + lastLine(p.lock) + "\n";
    for (const auto& [name, e] : p.launches)
      out += "  launches " + name + " as '" + e.peisName +
             "': " + (e.currState.empty() ? std::string("-") : e.currState) +
             (e.descriptor ? "" : " (no descriptor)") +
             (e.status.empty() || e.status == "ok" ? std::string() : ", " + e.status) + "\n";
  }
  return out;
}

std::string LiveModel::toJson() const {
  using json::quote;
  auto object = [](const std::map<std::string, std::string>& map) {
    std::string out = "{";
    for (const auto& [k, v] : map) out += (out.size() > 1 ? "," : "") + quote(k) + ":" + quote(v);
    return out + "}";
  };
  std::string out = "{\"peis\":[";
  for (std::size_t i = 0; i < peis.size(); ++i) {
    const auto& p = peis[i];
    out +=
        std::string(i ? "," : "") + "{\"id\":" + std::to_string(p.id) +
        ",\"name\":" + quote(p.name) + ",\"alive\":" + (p.alive ? "true" : "false") +
        ",\"radio\":" + (p.radio ? "true" : "false") +
        ",\"configurator\":" + (p.configurator ? "true" : "false") +
        ",\"component\":" + quote(p.component) + ",\"status\":" + quote(p.status) +
        ",\"causes\":" + quote(p.causes) +
        ",\"descriptor\":" + (p.descriptor ? quote(p.descriptor->toYaml()) : std::string("null")) +
        ",\"descriptorProblem\":" + quote(p.descriptorProblem) + ",\"links\":" + object(p.links) +
        ",\"actuators\":{";
    bool first = true;
    for (const auto& [name, a] : p.actuators) {
      out += std::string(first ? "" : ",") + quote(name) + ":{\"reqState\":" + quote(a.reqState) +
             ",\"currState\":" + quote(a.currState) + ",\"status\":" + quote(a.status) + "}";
      first = false;
    }
    out += "},\"facts\":[";
    for (std::size_t f = 0; f < p.facts.size(); ++f) out += (f ? "," : "") + quote(p.facts[f]);
    out += "],\"goals\":" + object(p.goals) + ",\"owned\":" + quote(p.owned) +
           ",\"lock\":" + quote(lastLine(p.lock)) + ",\"launches\":{";
    first = true;
    for (const auto& [name, e] : p.launches) {
      out += std::string(first ? "" : ",") + quote(name) + ":{\"peisName\":" + quote(e.peisName) +
             ",\"descriptor\":" + (e.descriptor ? "true" : "false") +
             ",\"reqState\":" + quote(e.reqState) + ",\"currState\":" + quote(e.currState) +
             ",\"status\":" + quote(e.status) + "}";
      first = false;
    }
    out += "}}";
  }
  return out + "]}";
}

std::string LiveModel::toYaml() const {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "peis" << YAML::Value << YAML::BeginSeq;
  for (const auto& p : peis) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << p.id;
    out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << p.name;
    out << YAML::Key << "alive" << YAML::Value << p.alive;
    out << YAML::Key << "radio" << YAML::Value << p.radio;
    out << YAML::Key << "incarnation" << YAML::Value << p.incarnation;
    out << YAML::Key << "configurator" << YAML::Value << p.configurator;
    out << YAML::Key << "component" << YAML::Value << YAML::DoubleQuoted << p.component;
    if (p.descriptor)
      out << YAML::Key << "descriptor" << YAML::Value << YAML::Literal << p.descriptor->toYaml();
    out << YAML::Key << "descriptor-problem" << YAML::Value << YAML::DoubleQuoted
        << p.descriptorProblem;
    out << YAML::Key << "status" << YAML::Value << YAML::DoubleQuoted << p.status;
    out << YAML::Key << "causes" << YAML::Value << YAML::DoubleQuoted << p.causes;
    out << YAML::Key << "links" << YAML::Value;
    emitMap(out, p.links);
    out << YAML::Key << "actuators" << YAML::Value << YAML::BeginMap;
    for (const auto& [name, a] : p.actuators) {
      out << YAML::Key << name << YAML::Value;
      emitMap(out, {{"reqState", a.reqState}, {"currState", a.currState}, {"status", a.status}});
    }
    out << YAML::EndMap;
    out << YAML::Key << "facts" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& f : p.facts) out << YAML::DoubleQuoted << f;
    out << YAML::EndSeq;
    out << YAML::Key << "goals" << YAML::Value;
    emitMap(out, p.goals);
    out << YAML::Key << "owned" << YAML::Value << YAML::DoubleQuoted << p.owned;
    out << YAML::Key << "lock" << YAML::Value << YAML::DoubleQuoted << p.lock;
    out << YAML::Key << "lock-seqno" << YAML::Value << p.lockSeqno;
    if (!p.launches.empty()) {
      out << YAML::Key << "launches" << YAML::Value << YAML::BeginMap;
      for (const auto& [name, e] : p.launches) {
        out << YAML::Key << name << YAML::Value << YAML::BeginMap;
        for (const auto& [k, v] :
             std::map<std::string, std::string>{{"peis-name", e.peisName},
                                                {"descriptor-problem", e.descriptorProblem},
                                                {"reqState", e.reqState},
                                                {"currState", e.currState},
                                                {"status", e.status}})
          out << YAML::Key << k << YAML::Value << YAML::DoubleQuoted << v;
        if (e.descriptor)
          out << YAML::Key << "descriptor" << YAML::Value << YAML::Literal
              << e.descriptor->toYaml();
        out << YAML::EndMap;
      }
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

LiveModel LiveModel::fromYaml(std::string_view yamlText, std::string_view origin) {
  const YAML::Node root = yaml::load(yamlText, origin);
  return yaml::guarded(origin, [&] { return parseLiveModel(root, origin); });
}

static LiveModel parseLiveModel(const YAML::Node& root, std::string_view origin) {
  LiveModel model;
  if (!root || root.IsNull()) return model;
  yaml::onlyKeys(origin, root, {"peis"}, "a live model");
  for (const auto& node : yaml::sequence(origin, root["peis"], "peis")) {
    yaml::onlyKeys(origin, node,
                   {"id", "name", "alive", "radio", "incarnation", "configurator", "component",
                    "descriptor", "descriptor-problem", "status", "causes", "links", "actuators",
                    "facts", "goals", "owned", "lock", "lock-seqno", "launches"},
                   "a PEIS");
    LivePeis p;
    try {
      p.id = node["id"].as<int>();
      if (node["incarnation"]) p.incarnation = node["incarnation"].as<std::int64_t>();
      if (node["lock-seqno"]) p.lockSeqno = node["lock-seqno"].as<std::uint64_t>();
    } catch (const YAML::Exception&) {
      yaml::fail(origin, node, "id, incarnation and lock-seqno must be numbers");
    }
    p.name = yaml::scalar(origin, node["name"], "name");
    if (node["alive"]) p.alive = yaml::boolean(origin, node["alive"], "alive");
    if (node["radio"]) p.radio = yaml::boolean(origin, node["radio"], "radio");
    if (node["configurator"])
      p.configurator = yaml::boolean(origin, node["configurator"], "configurator");
    p.component = text(origin, node["component"], "component");
    if (node["descriptor"])
      p.descriptor = Descriptor::fromYaml(yaml::scalar(origin, node["descriptor"], "descriptor"),
                                          std::string(origin) + " (descriptor of " + p.name + ")");
    p.descriptorProblem = text(origin, node["descriptor-problem"], "descriptor-problem");
    p.status = text(origin, node["status"], "status");
    p.causes = text(origin, node["causes"], "causes");
    p.links = readMap(origin, node["links"], "links");
    if (const auto actuators = node["actuators"]) {
      if (!actuators.IsMap()) yaml::fail(origin, actuators, "actuators must be a mapping");
      for (const auto& item : actuators) {
        auto fields = readMap(origin, item.second, "an actuator");
        p.actuators[item.first.as<std::string>()] =
            ActuatorState{fields["reqState"], fields["currState"], fields["status"]};
      }
    }
    if (node["facts"]) {
      for (const auto& f : yaml::sequence(origin, node["facts"], "facts"))
        p.facts.push_back(yaml::scalar(origin, f, "a fact"));
    }
    p.goals = readMap(origin, node["goals"], "goals");
    p.owned = text(origin, node["owned"], "owned");
    p.lock = text(origin, node["lock"], "lock");
    if (const auto launches = node["launches"]) {
      if (!launches.IsMap()) yaml::fail(origin, launches, "launches must be a mapping");
      for (const auto& item : launches) {
        const auto name = item.first.as<std::string>();
        yaml::onlyKeys(
            origin, item.second,
            {"peis-name", "descriptor", "descriptor-problem", "reqState", "currState", "status"},
            "a launched component");
        LaunchEntry e;
        e.peisName = text(origin, item.second["peis-name"], "peis-name");
        if (item.second["descriptor"])
          e.descriptor =
              Descriptor::fromYaml(yaml::scalar(origin, item.second["descriptor"], "descriptor"),
                                   std::string(origin) + " (descriptor of component " + name + ")");
        e.descriptorProblem = text(origin, item.second["descriptor-problem"], "descriptor-problem");
        e.reqState = text(origin, item.second["reqState"], "reqState");
        e.currState = text(origin, item.second["currState"], "currState");
        e.status = text(origin, item.second["status"], "status");
        p.launches[name] = std::move(e);
      }
    }
    model.peis.push_back(std::move(p));
  }
  return model;
}

}  // namespace peis::meta
