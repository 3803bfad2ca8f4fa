// The component conventions' key names, in one place: the component library
// writes them, the meta-level and the tools read them (docs/components.md).
//
//   status                    initializing | waiting | running | error
//   cause.names               inputs missing or stale while waiting (or the
//                             error's cause), space-separated
//   mi-<input>                meta tuple a configurator points at a producer
//   <act>.reqState / .currState / .status   one actuator
//   component.name, component.descriptor    who this is, its YAML descriptor
//   functionalities, functionality.<f>.*   the descriptor as tuples
//   fact.<name>[.<arg>…]      a fact for preconditions: `in-view(pippi, cam1)`
//                             is `fact.in-view.pippi.cam1` = `true`
//   <activation>.reqState     `on` / `off` (or the active bindings) for a
//                             functionality with an activation actuator
#pragma once

#include <string>
#include <string_view>

namespace peis::conventions {

inline constexpr std::string_view kStatus = "status";
inline constexpr std::string_view kCauseNames = "cause.names";
inline constexpr std::string_view kComponentName = "component.name";
inline constexpr std::string_view kComponentDescriptor = "component.descriptor";
inline constexpr std::string_view kFunctionalities = "functionalities";
inline constexpr std::string_view kMetaInputPrefix = "mi-";
inline constexpr std::string_view kFunctionalityPrefix = "functionality.";

// Values of `status`.
inline constexpr std::string_view kInitializing = "initializing";
inline constexpr std::string_view kWaiting = "waiting";
inline constexpr std::string_view kRunning = "running";
inline constexpr std::string_view kError = "error";

// Suffixes of an actuator's tuples, and the values of <act>.status.
inline constexpr std::string_view kReqState = ".reqState";
inline constexpr std::string_view kCurrState = ".currState";
inline constexpr std::string_view kActuatorStatus = ".status";
inline constexpr std::string_view kActuatorOk = "ok";
inline constexpr std::string_view kActuatorBusy = "busy";

// Facts (docs/configuration.md): a component that observes a fact writes
// `fact.<name>.<arg1>.<arg2>…` in its own namespace with the data `true`. Any
// other data, deletion or expiry means the fact does not hold (now). Facts are
// global: the planner takes the union over all PEIS.
inline constexpr std::string_view kFactPrefix = "fact.";
inline constexpr std::string_view kFactTrue = "true";

// Values of a functionality's activation actuator (`<activation>.reqState`):
// `on` / `off` for a functionality without variables; with variables, the
// active bindings `var=value,var=value` (without `?`), one per active
// instance, separated by one space, or `off` when none is active.
inline constexpr std::string_view kActivationOn = "on";
inline constexpr std::string_view kActivationOff = "off";

// "in-view", {"pippi", "cam1"} -> "fact.in-view.pippi.cam1".
template <typename Args>
std::string factKey(std::string_view name, const Args& args) {
  std::string key = std::string(kFactPrefix) + std::string(name);
  for (const auto& arg : args) key += "." + std::string(arg);
  return key;
}

// "position" -> "mi-position": the meta tuple of a component input.
inline std::string metaInputKey(std::string_view input) {
  return std::string(kMetaInputPrefix) + std::string(input);
}
// "mi-position" -> "position"; empty when `key` is not a meta input key.
inline std::string inputOfMetaKey(std::string_view key) {
  if (key.substr(0, kMetaInputPrefix.size()) != kMetaInputPrefix) return {};
  return std::string(key.substr(kMetaInputPrefix.size()));
}
// "light" -> "light.reqState", and so on.
inline std::string reqStateKey(std::string_view actuator) {
  return std::string(actuator) + std::string(kReqState);
}
inline std::string currStateKey(std::string_view actuator) {
  return std::string(actuator) + std::string(kCurrState);
}
inline std::string actuatorStatusKey(std::string_view actuator) {
  return std::string(actuator) + std::string(kActuatorStatus);
}
// "track" + "inputs" -> "functionality.track.inputs".
inline std::string functionalityKey(std::string_view functionality, std::string_view field) {
  return std::string(kFunctionalityPrefix) + std::string(functionality) + "." + std::string(field);
}

}  // namespace peis::conventions

namespace peis {
using conventions::metaInputKey;
}  // namespace peis
