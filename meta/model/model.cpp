// The model file (docs/configuration.md, "The model file"), link costs and
// PEIS lookup of peis::meta::Model.
#include "peis/meta/model.h"

#include <charconv>
#include <filesystem>

#include "model/yaml_util.h"
#include "peis/descriptor_yaml.h"

namespace peis::meta {
namespace {

PeisInfo peisEntry(std::string_view origin, const YAML::Node& node,
                   const std::filesystem::path& baseDir) {
  yaml::onlyKeys(origin, node, {"id", "name", "alive", "radio", "components"}, "a PEIS");
  PeisInfo p;
  p.name = yaml::scalar(origin, yaml::field(origin, node, "name", "PEIS name"), "PEIS name");
  if (auto problem = Term::parse(p.name); !problem || !problem->args.empty()) {
    yaml::fail(origin, node["name"], "PEIS name '" + p.name + "' must be one plain word");
  }
  if (node["id"]) {
    const auto text = yaml::scalar(origin, node["id"], "PEIS id");
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), p.id);
    if (ec != std::errc() || ptr != text.data() + text.size() || p.id < 0) {
      yaml::fail(origin, node["id"], "PEIS id '" + text + "' must be a number >= 0");
    }
  }
  if (node["alive"]) p.alive = yaml::boolean(origin, node["alive"], "alive");
  if (node["radio"]) p.radio = yaml::boolean(origin, node["radio"], "radio");
  if (const auto list = node["components"]) {
    for (const auto& item : yaml::sequence(origin, list, "components")) {
      if (item.IsMap() && item["descriptor"]) {
        yaml::onlyKeys(origin, item, {"descriptor"}, "a component given by file");
        auto path = std::filesystem::path(yaml::scalar(origin, item["descriptor"], "descriptor"));
        if (path.is_relative()) path = baseDir / path;
        try {
          p.components.push_back(Descriptor::fromFile(path.string()));
        } catch (const Error& e) {
          yaml::fail(origin, item["descriptor"], std::string("in the descriptor: ") + e.what());
        }
      } else {
        p.components.push_back(descriptorFromNode(item, origin));
      }
    }
  }
  return p;
}

Fact factEntry(std::string_view origin, const YAML::Node& node) {
  Fact f;
  YAML::Node atom = node;
  if (node.IsMap()) {
    yaml::onlyKeys(origin, node, {"fact", "publisher"}, "a fact");
    atom.reset(yaml::field(origin, node, "fact", "fact"));
    if (node["publisher"]) f.publisher = yaml::scalar(origin, node["publisher"], "publisher");
  }
  f.atom = yaml::term(origin, atom, "fact");
  if (!f.atom.isGround())
    yaml::fail(origin, atom, "fact '" + f.atom.toString() + "' has a variable");
  return f;
}

InstanceSelector selectorEntry(std::string_view origin, const YAML::Node& node,
                               const std::string& what) {
  const auto text = yaml::scalar(origin, node, what);
  std::string problem;
  auto s = InstanceSelector::parse(text, &problem);
  if (!s) yaml::fail(origin, node, what + " '" + text + "': " + problem);
  return *s;
}

Model parseModel(std::string_view text, std::string_view origin) {
  const auto root = yaml::load(text, origin);
  if (!root.IsDefined() || root.IsNull()) return {};
  yaml::onlyKeys(origin, root, {"peis", "facts", "link-costs", "link-overrides", "failed"},
                 "the model");
  Model m;
  const auto baseDir = std::filesystem::path(std::string(origin)).parent_path();
  if (const auto list = root["peis"]) {
    for (const auto& item : yaml::sequence(origin, list, "peis")) {
      m.peis.push_back(peisEntry(origin, item, baseDir));
      for (std::size_t i = 0; i + 1 < m.peis.size(); ++i) {
        if (m.peis[i].name == m.peis.back().name) {
          yaml::fail(origin, item, "PEIS '" + m.peis.back().name + "' is declared twice");
        }
        if (m.peis.back().id != 0 && m.peis[i].id == m.peis.back().id) {
          yaml::fail(origin, item,
                     "PEIS id " + std::to_string(m.peis.back().id) + " is used twice");
        }
      }
    }
  }
  if (const auto list = root["facts"]) {
    for (const auto& item : yaml::sequence(origin, list, "facts")) {
      m.facts.push_back(factEntry(origin, item));
    }
  }
  if (const auto costs = root["link-costs"]) {
    yaml::onlyKeys(origin, costs, {"local", "lan", "radio"}, "link-costs");
    if (costs["local"]) m.linkCosts.local = yaml::number(origin, costs["local"], "local");
    if (costs["lan"]) m.linkCosts.lan = yaml::number(origin, costs["lan"], "lan");
    if (costs["radio"]) m.linkCosts.radio = yaml::number(origin, costs["radio"], "radio");
  }
  if (const auto list = root["link-overrides"]) {
    for (const auto& item : yaml::sequence(origin, list, "link-overrides")) {
      yaml::onlyKeys(origin, item, {"producer", "consumer", "cost"}, "a link override");
      LinkCostOverride o{
          yaml::scalar(origin, yaml::field(origin, item, "producer", "producer"), "producer"),
          yaml::scalar(origin, yaml::field(origin, item, "consumer", "consumer"), "consumer"),
          yaml::number(origin, yaml::field(origin, item, "cost", "cost"), "cost")};
      for (const auto* name : {&o.producer, &o.consumer}) {
        if (!m.findPeis(*name)) {
          yaml::fail(origin, item, "link override names the unknown PEIS '" + *name + "'");
        }
      }
      m.linkOverrides.push_back(o);
    }
  }
  if (const auto list = root["failed"]) {
    for (const auto& item : yaml::sequence(origin, list, "failed")) {
      m.failed.push_back(selectorEntry(origin, item, "failed instance"));
    }
  }
  return m;
}

}  // namespace

const char* toString(LinkKind kind) {
  switch (kind) {
    case LinkKind::Local:
      return "local";
    case LinkKind::Lan:
      return "lan";
    case LinkKind::Radio:
      return "radio";
  }
  return "lan";
}

double LinkCosts::of(LinkKind kind) const {
  return kind == LinkKind::Local ? local : kind == LinkKind::Radio ? radio : lan;
}

Model Model::fromYaml(std::string_view text, std::string_view origin) {
  return yaml::guarded(origin, [&] { return parseModel(text, origin); });
}

Model Model::fromFile(const std::string& path) {
  return fromYaml(yaml::readFile(path, "model file"), path);
}

std::string Model::toYaml() const {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "link-costs" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "local" << YAML::Value << linkCosts.local;
  out << YAML::Key << "lan" << YAML::Value << linkCosts.lan;
  out << YAML::Key << "radio" << YAML::Value << linkCosts.radio << YAML::EndMap;
  if (!linkOverrides.empty()) {
    out << YAML::Key << "link-overrides" << YAML::Value << YAML::BeginSeq;
    for (const auto& o : linkOverrides) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "producer" << YAML::Value << o.producer
          << YAML::Key << "consumer" << YAML::Value << o.consumer << YAML::Key << "cost"
          << YAML::Value << o.cost << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::Key << "peis" << YAML::Value << YAML::BeginSeq;
  for (const auto& p : peis) {
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << p.name;
    out << YAML::Key << "id" << YAML::Value << p.id;
    if (!p.alive) out << YAML::Key << "alive" << YAML::Value << false;
    if (p.radio) out << YAML::Key << "radio" << YAML::Value << true;
    out << YAML::Key << "components" << YAML::Value << YAML::BeginSeq;
    for (const auto& d : p.components) out << YAML::Load(d.toYaml());
    out << YAML::EndSeq << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!facts.empty()) {
    out << YAML::Key << "facts" << YAML::Value << YAML::BeginSeq;
    for (const auto& f : facts) {
      if (f.publisher.empty()) {
        out << f.atom.toString();
      } else {
        out << YAML::Flow << YAML::BeginMap << YAML::Key << "fact" << YAML::Value
            << f.atom.toString() << YAML::Key << "publisher" << YAML::Value << f.publisher
            << YAML::EndMap;
      }
    }
    out << YAML::EndSeq;
  }
  if (!failed.empty()) {
    out << YAML::Key << "failed" << YAML::Value << YAML::BeginSeq;
    for (const auto& s : failed) out << s.toString();
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

const PeisInfo* Model::findPeis(std::string_view nameOrId) const {
  for (const auto& p : peis) {
    if (p.name == nameOrId) return &p;
  }
  int id = 0;
  const auto [ptr, ec] = std::from_chars(nameOrId.data(), nameOrId.data() + nameOrId.size(), id);
  if (ec == std::errc() && ptr == nameOrId.data() + nameOrId.size()) {
    for (const auto& p : peis) {
      if (p.id == id && id != 0) return &p;
    }
  }
  return nullptr;
}

LinkKind Model::linkKind(const PeisInfo& producer, const PeisInfo& consumer) const {
  if (&producer == &consumer || producer.name == consumer.name) return LinkKind::Local;
  return producer.radio || consumer.radio ? LinkKind::Radio : LinkKind::Lan;
}

double Model::linkCost(const PeisInfo& producer, const PeisInfo& consumer) const {
  for (const auto& o : linkOverrides) {
    if (o.producer == producer.name && o.consumer == consumer.name) return o.cost;
  }
  return linkCosts.of(linkKind(producer, consumer));
}

}  // namespace peis::meta
