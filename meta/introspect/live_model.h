// The live model of an ecology, as introspection sees it from the tuples: each
// PEIS (alive or gone, a tiny node behind the bridge or not), the component it
// runs and its descriptor, where each of its meta inputs `mi-*` points now,
// its `status` and `cause.names`, the activation actuators its descriptor
// names, the facts it publishes, and the meta-level's own records on it
// (`config.owned`, `config.lock`, `config.goal.*`). A value type with pure
// conversions: to the planner's `Model`, to text for a person, to JSON, and
// to and from YAML (how the configurator publishes it as the tuple
// `model.live`). docs/configuration.md, "Introspection".
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/descriptor.h"
#include "peis/meta/model.h"

namespace peis::meta {

// One actuator's tuples (`<name>.reqState`, `.currState`, `.status`).
struct ActuatorState {
  std::string reqState, currState, status;
  bool operator==(const ActuatorState&) const = default;
};

// A component that a launcher (peis-init) declares: its `components.<name>.*`
// tuples (docs/operating.md, "The launcher"). The configurator plans with the
// ones that are not running and asks the launcher to start those it uses.
struct LaunchEntry {
  std::string peisName;                  // `.peisName`: the PEIS it joins as
  std::optional<Descriptor> descriptor;  // `.descriptor`
  std::string descriptorProblem;         // why the published descriptor was not usable
  std::string reqState, currState, status;
  bool operator==(const LaunchEntry&) const = default;
};

struct LivePeis {
  int id = 0;
  std::string name;
  bool alive = true;
  bool radio = false;                        // a tiny node's proxy (it has `tiny.bridge`)
  std::int64_t incarnation = 0;              // start time in µs, as PeerInfo says
  std::string component;                     // `component.name`; empty: no component
  std::optional<Descriptor> descriptor;      // from `component.descriptor`
  std::string descriptorProblem;             // why the published descriptor was not usable
  std::string status;                        // `status` (empty: none published)
  std::string causes;                        // `cause.names`
  std::map<std::string, std::string> links;  // meta input key -> its data (`ID.KEY`, or empty)
  std::map<std::string, ActuatorState> actuators;  // activation actuators of the descriptor
  std::vector<std::string> facts;  // ground atoms in canonical form (`in-view(pippi,cam1)`)
  std::map<std::string, std::string> goals;  // `config.goal.<label>` key -> its text
  std::string owned;                         // `config.owned`: what the configuration wrote here
  std::string lock;                          // `config.lock`: who deploys here (last line counts)
  std::uint64_t lockSeqno = 0;               // the lock tuple's seqno (0: absent)
  bool configurator = false;                 // publishes `config.configurator`
  std::map<std::string, LaunchEntry> launches;  // a launcher's components, by name
  bool operator==(const LivePeis&) const = default;
};

struct LiveModel {
  std::vector<LivePeis> peis;  // ordered by id

  const LivePeis* find(int id) const;
  // The alive PEIS of that name, else a gone one, else nothing.
  const LivePeis* findByName(std::string_view name) const;
  // A component that an alive launcher declares to run as PEIS `peisName`,
  // with a descriptor, and that is not `failed` or `restarting`: where to
  // ask for it (the launcher's PEIS and the component's name).
  struct Launchable {
    const LivePeis* launcher = nullptr;
    std::string component;
    const LaunchEntry* entry = nullptr;
  };
  std::optional<Launchable> launchable(std::string_view peisName) const;
  // A meta tuple's data (`OWNER.KEY`, OWNER an id or a name) as `ID.KEY`;
  // unchanged when it names no PEIS known here.
  std::string canonicalTarget(const std::string& data) const;

  // The planner's model: every PEIS with its descriptor (PEIS without one
  // can still be consumers), alive or dead, radio for tiny nodes, the facts
  // of alive PEIS with their publisher. A PEIS whose name is not one plain
  // word for the planner is named `peis-<id>`; a dead PEIS whose name an
  // alive one carries (a restart under a new id) is left out, and of dead
  // PEIS of one name only the last life is kept. A component an alive
  // launcher can start (launchable()) whose PEIS is not alive is in the
  // model as an alive PEIS of id 0 with its descriptor: the planner may use
  // it, and the configurator starts it before it deploys.
  Model toModel(const LinkCosts& costs = {},
                const std::vector<LinkCostOverride>& overrides = {}) const;

  // For a person (`peis config model`): one block per PEIS.
  std::string toText() const;
  std::string toJson() const;
  // The form published as `model.live`; fromYaml(toYaml()) == *this.
  std::string toYaml() const;
  // Throws Error(InvalidConfig) "<origin>:<line>: <problem>".
  static LiveModel fromYaml(std::string_view text, std::string_view origin = "<live model>");
  bool operator==(const LiveModel&) const = default;
};

// `fact.in-view.pippi.cam1` -> `in-view(pippi,cam1)`; nothing when the key is
// not a fact key or its parts are not a term.
std::optional<Term> factOfKey(std::string_view key);

}  // namespace peis::meta
