// Reading and writing functionality descriptors (YAML, via yaml-cpp).
#include "peis/descriptor.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "peis/descriptor_yaml.h"
#include "peis/error.h"
#include "peis/key.h"

namespace peis {
namespace {

[[noreturn]] void fail(std::string_view origin, const YAML::Node& node, const std::string& why) {
  std::string where(origin);
  // A missing key of a const map is an invalid node, whose Mark() throws.
  if (node.IsDefined() && node.Mark().line >= 0)
    where += ":" + std::to_string(node.Mark().line + 1);
  throw Error(ErrorCode::InvalidConfig, where + ": " + why);
}

void onlyKeys(std::string_view origin, const YAML::Node& map, const std::set<std::string>& allowed,
              const std::string& what) {
  if (!map.IsMap()) fail(origin, map, what + " must be a mapping");
  for (const auto& item : map) {
    const auto key = item.first.as<std::string>();
    if (!allowed.count(key)) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      fail(origin, item.first, "unknown key '" + key + "' in " + what + " (known: " + list + ")");
    }
  }
}

// The value of a required key; when it is missing, the error names the line
// of the mapping that lacks it.
YAML::Node field(std::string_view origin, const YAML::Node& map, const char* key,
                 const std::string& what) {
  const YAML::Node node = map[key];
  if (!node) fail(origin, map, what + " is missing");
  return node;
}

std::string scalar(std::string_view origin, const YAML::Node& node, const std::string& what) {
  if (!node) fail(origin, node, what + " is missing");
  if (!node.IsScalar()) fail(origin, node, what + " must be a plain value");
  return node.as<std::string>();
}

std::string keyPart(std::string_view origin, const YAML::Node& node, const std::string& what) {
  auto value = scalar(origin, node, what);
  if (auto problem = keyProblem(value); problem || value.find('.') != std::string::npos) {
    fail(origin, node, what + " '" + value + "' must be one key part (no '.', '*', '=', spaces)");
  }
  return value;
}

// The key with each `?var` replaced by a sample value, for checking it.
std::string sampleKey(std::string key) {
  for (std::size_t at = key.find('?'); at != std::string::npos; at = key.find('?', at)) {
    auto end = at + 1;
    while (end < key.size() && key[end] != '.') ++end;
    key.replace(at, end - at, "x");
  }
  return key;
}

Port port(std::string_view origin, const YAML::Node& item, const std::string& what, bool input) {
  onlyKeys(origin, item, {"name", "type", "key"}, "an entry of " + what);
  Port port{keyPart(origin, field(origin, item, "name", what + " name"), what + " name"),
            scalar(origin, field(origin, item, "type", what + " type"), what + " type"), ""};
  std::string problem;
  const auto type = Term::parse(port.type, &problem);
  if (!type) {
    fail(origin, item["type"], what + " type '" + port.type + "' is not a term: " + problem);
  }
  port.type = type->toString();
  if (const auto key = item["key"]) {
    port.key = scalar(origin, key, what + " key");
    if (input && port.key.rfind("mi-", 0) != 0) {
      fail(origin, key,
           "the key of input '" + port.name + "' must start with 'mi-' (a meta input)");
    }
    if (auto bad = keyProblem(sampleKey(port.key))) {
      fail(origin, key, what + " key '" + port.key + "' is not a valid key: " + *bad);
    }
  }
  return port;
}

std::vector<Port> ports(std::string_view origin, const YAML::Node& node, const std::string& what) {
  std::vector<Port> result;
  if (!node) return result;
  if (!node.IsSequence()) fail(origin, node, what + " must be a list");
  for (const auto& item : node) result.push_back(port(origin, item, what, what == "inputs"));
  return result;
}

// Variables must be bound by a type or an atom; keys must be distinct.
void checkVariables(std::string_view origin, const YAML::Node& node, const Functionality& f,
                    const std::vector<Precondition>& preconditions) {
  std::set<std::string> bound{std::string(kSelfVariable)};
  for (const auto* list : {&f.inputs, &f.outputs}) {
    for (const auto& p : *list) {
      for (const auto& v : Term::parse(p.type)->variables()) bound.insert(v);
    }
  }
  for (const auto& p : preconditions) {
    if (!p.disequality) {
      for (const auto& v : p.atom.variables()) bound.insert(v);
    }
  }
  for (const auto& p : preconditions) {
    for (const auto& side : {p.left, p.right}) {
      if (p.disequality && isVariable(side) && !bound.count(side)) {
        fail(origin, node,
             "functionality '" + f.name + "': variable " + side + " in '" + p.toString() +
                 "' appears in no type and no atom");
      }
    }
    if (p.disequality && p.left == p.right) {
      fail(origin, node,
           "functionality '" + f.name + "': precondition '" + p.toString() + "' can never hold");
    }
  }
  std::set<std::string> keys;
  for (const auto& p : f.outputs) {
    if (!keys.insert(p.outputKey()).second) {
      fail(origin, node,
           "functionality '" + f.name + "' writes two outputs to the key '" + p.outputKey() + "'");
    }
  }
}

Functionality functionality(std::string_view origin, const YAML::Node& node) {
  onlyKeys(origin, node,
           {"name", "description", "inputs", "outputs", "preconditions", "activation", "cost"},
           "a functionality");
  Functionality f;
  f.name = keyPart(origin, field(origin, node, "name", "functionality name"), "functionality name");
  if (node["description"]) f.description = scalar(origin, node["description"], "description");
  f.inputs = ports(origin, node["inputs"], "inputs");
  f.outputs = ports(origin, node["outputs"], "outputs");
  std::vector<Precondition> parsed;
  if (const auto pre = node["preconditions"]) {
    if (!pre.IsSequence()) fail(origin, pre, "preconditions must be a list");
    for (const auto& item : pre) {
      const auto text = scalar(origin, item, "a precondition");
      std::string problem;
      auto p = Precondition::parse(text, &problem);
      if (!p) fail(origin, item, "precondition '" + text + "' is not an atom: " + problem);
      f.preconditions.push_back(p->toString());
      parsed.push_back(std::move(*p));
    }
  }
  if (const auto act = node["activation"]) {
    f.activation = scalar(origin, act, "activation");
    if (auto problem = keyProblem(f.activation + ".reqState")) {
      fail(origin, act, "activation '" + f.activation + "' is not an actuator name: " + *problem);
    }
  }
  if (const auto cost = node["cost"]) {
    try {
      f.cost = cost.as<double>();
    } catch (const YAML::Exception&) {
      fail(origin, cost, "cost must be a number");
    }
    if (!std::isfinite(f.cost) || f.cost < 0) fail(origin, cost, "cost must be finite and >= 0");
  }
  checkVariables(origin, node, f, parsed);
  return f;
}

Descriptor parseDescriptor(std::string_view text, std::string_view origin);

}  // namespace

Descriptor Descriptor::fromYaml(std::string_view text, std::string_view origin) {
  try {
    return parseDescriptor(text, origin);
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::InvalidConfig,
                std::string(origin) + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

namespace {
Descriptor parseDescriptor(std::string_view text, std::string_view origin) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(text));
  } catch (const YAML::Exception& e) {
    throw Error(
        ErrorCode::InvalidConfig,
        std::string(origin) + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  return descriptorFromNode(root, origin);
}
}  // namespace

Descriptor descriptorFromNode(const YAML::Node& root, std::string_view origin) {
  onlyKeys(origin, root, {"component", "functionalities"}, "the descriptor");
  Descriptor d;
  d.component = keyPart(origin, field(origin, root, "component", "component"), "component");
  const auto list = root["functionalities"];
  if (list) {
    if (!list.IsSequence()) fail(origin, list, "functionalities must be a list");
    std::set<std::string> seen;
    for (const auto& item : list) {
      d.functionalities.push_back(functionality(origin, item));
      if (!seen.insert(d.functionalities.back().name).second) {
        fail(origin, item,
             "functionality '" + d.functionalities.back().name + "' is declared twice");
      }
    }
  }
  return d;
}

Descriptor Descriptor::fromFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorCode::InvalidConfig, path + ": cannot open the descriptor file");
  std::stringstream text;
  text << in.rdbuf();
  return fromYaml(text.str(), path);
}

std::string Descriptor::toYaml() const {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "component" << YAML::Value << component;
  out << YAML::Key << "functionalities" << YAML::Value << YAML::BeginSeq;
  for (const auto& f : functionalities) {
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << f.name;
    if (!f.description.empty()) out << YAML::Key << "description" << YAML::Value << f.description;
    for (const auto* list : {&f.inputs, &f.outputs}) {
      out << YAML::Key << (list == &f.inputs ? "inputs" : "outputs") << YAML::Value
          << YAML::BeginSeq;
      for (const auto& p : *list) {
        out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << p.name
            << YAML::Key << "type" << YAML::Value << p.type;
        if (!p.key.empty()) out << YAML::Key << "key" << YAML::Value << p.key;
        out << YAML::EndMap;
      }
      out << YAML::EndSeq;
    }
    out << YAML::Key << "preconditions" << YAML::Value << YAML::Flow << f.preconditions;
    if (!f.activation.empty()) out << YAML::Key << "activation" << YAML::Value << f.activation;
    out << YAML::Key << "cost" << YAML::Value << f.cost << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return out.c_str();
}

}  // namespace peis
