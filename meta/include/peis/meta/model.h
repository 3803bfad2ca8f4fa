// The functionality model the configuration planner works on: the PEIS of an
// ecology, the components each one runs (their functionality descriptors),
// the facts published for preconditions, and the cost of a link between two
// PEIS. A value type, built by introspection from tuples or read from a model
// file (docs/configuration.md, "The model file"). Pure: no I/O but fromFile.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/descriptor.h"

namespace peis::meta {

// How two PEIS are connected, which sets the cost of a link between them.
enum class LinkKind {
  Local,  // consumer and producer on the same PEIS
  Lan,    // two full PEIS (TCP over the LAN or loopback)
  Radio,  // either end is a tiny node reached through the tinybridge's radio
};
const char* toString(LinkKind kind);

// The documented defaults (docs/configuration.md); a model file can change them.
struct LinkCosts {
  double local = 0.1;
  double lan = 1.0;
  double radio = 4.0;
  double of(LinkKind kind) const;
  bool operator==(const LinkCosts&) const = default;
};

// A link cost for one ordered pair of PEIS (producer -> consumer), by name.
struct LinkCostOverride {
  std::string producer;
  std::string consumer;
  double cost = 0;
  bool operator==(const LinkCostOverride&) const = default;
};

struct PeisInfo {
  int id = 0;
  std::string name;    // unique in the model; also how goals name the PEIS
  bool alive = true;   // a dead PEIS is kept for explanations, never planned on
  bool radio = false;  // a tiny node behind the tinybridge
  std::vector<Descriptor> components;
  bool operator==(const PeisInfo&) const = default;
};

// A published fact (`fact.<name>.<args>` = `true` on `publisher`).
struct Fact {
  Term atom;              // ground
  std::string publisher;  // PEIS name, for explanations; may be empty
  bool operator==(const Fact&) const = default;
};

// Names one functionality instance, or a set of them: empty fields match
// anything. `binding` lists variable values that must hold ("?robot" -> "pippi").
struct InstanceSelector {
  std::string peis;  // PEIS name (or id as text)
  std::string component;
  std::string functionality;
  std::map<std::string, std::string> binding;
  std::string toString() const;  // `peis/component/functionality{?r=pippi}`
  static std::optional<InstanceSelector> parse(std::string_view text, std::string* problem);
  bool operator==(const InstanceSelector&) const = default;
};

struct Model {
  std::vector<PeisInfo> peis;
  std::vector<Fact> facts;
  LinkCosts linkCosts;
  std::vector<LinkCostOverride> linkOverrides;
  // Functionality instances seen failing (by the execution monitor): never planned.
  std::vector<InstanceSelector> failed;

  // Reads a model file; throws Error(InvalidConfig) "<origin>:<line>: <problem>".
  static Model fromYaml(std::string_view text, std::string_view origin = "<model>");
  static Model fromFile(const std::string& path);
  std::string toYaml() const;

  const PeisInfo* findPeis(std::string_view nameOrId) const;
  // The cost of a link producer -> consumer under linkCosts and linkOverrides.
  double linkCost(const PeisInfo& producer, const PeisInfo& consumer) const;
  LinkKind linkKind(const PeisInfo& producer, const PeisInfo& consumer) const;
  bool operator==(const Model&) const = default;
};

}  // namespace peis::meta
