// What `peis info` says about one PEIS, read from its tuples: the kernel's
// own (name, host, links, subscribers) and those of the component
// conventions (peis/conventions.h, docs/components.md: status, cause.names,
// mi-<input>, component.outputs, <act>.reqState/currState/status,
// functionalities). Pure.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "peis/tuple.h"

namespace peis::cli {

struct InputInfo {
  std::string name;    // "brightness" for mi-brightness
  std::string target;  // what the meta tuple holds ("11.brightness"), "" for nowhere
  std::optional<PeisId> targetOwner;
  bool missing = false;  // listed in cause.names while waiting
};

struct ActuatorInfo {
  std::string name, reqState, currState, status;
};

struct PeisInfo {
  PeisId id = 0;
  std::string name, host, user, version, port;
  double upSeconds = -1;
  std::vector<PeisId> links, subscribers;
  std::string component;  // component.name; empty: no component
  std::string status, causes;
  std::vector<InputInfo> inputs;
  std::vector<std::string> outputs, functionalities;
  std::vector<ActuatorInfo> actuators;
};

// From the tuples of PEIS `id` (others are ignored); `now` for the up-time.
PeisInfo collectInfo(PeisId id, const std::vector<Tuple>& tuples, Timestamp now);

// The name of a PEIS, or "" when not known: supplied by the caller.
using NameOf = std::function<std::string(PeisId)>;
// Lines for a person.
std::string formatInfo(const PeisInfo& info, const NameOf& nameOf);
// One JSON object.
std::string infoJson(const PeisInfo& info);

}  // namespace peis::cli
