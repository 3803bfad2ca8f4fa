// The component conventions' key names, in one place: the component library
// writes them, the meta-level and the tools read them (docs/components.md).
//
//   status                    initializing | waiting | running | error
//   cause.names               inputs missing or stale while waiting (or the
//                             error's cause), space-separated
//   mi-<input>                meta tuple a configurator points at a producer
//   <act>.reqState / .currState / .status   one actuator
//   component.name, component.descriptor    who this is, its YAML descriptor
//   component.outputs         the keys it writes, space-separated
//   functionalities, functionality.<f>.*   the descriptor as tuples
#pragma once

#include <string>
#include <string_view>

namespace peis::conventions {

inline constexpr std::string_view kStatus = "status";
inline constexpr std::string_view kCauseNames = "cause.names";
inline constexpr std::string_view kComponentName = "component.name";
inline constexpr std::string_view kComponentDescriptor = "component.descriptor";
inline constexpr std::string_view kComponentOutputs = "component.outputs";
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
