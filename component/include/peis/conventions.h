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
//   fact.<name>[.<arg>…]      a fact for preconditions: `in-view(pippi, cam1)`
//                             is `fact.in-view.pippi.cam1` = `true`
//   <activation>.reqState     `on` / `off` (or the active bindings) for a
//                             functionality with an activation actuator
//   components.<c>.<field>    a launcher's (peis-init) tuples of component c:
//                             reqState, currState, status, peisName, descriptor…
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>

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

// --- The launcher (peis-init, docs/operating.md) ---------------------------------
// A launcher PEIS starts and stops the components of one machine. In its
// namespace, for each component c of its component files, it publishes
// `components.<c>.<field>`; `components.<c>` is an actuator of the convention
// above: anyone writes `components.<c>.reqState` = `on` / `off`, the
// launcher answers in `.currState` and `.status`. `.peisName` is the PEIS
// name c joins as, `.descriptor` its functionality descriptor (YAML), so the
// meta-level can plan with components that do not run yet.
inline constexpr std::string_view kLauncherComponents = "launcher.components";  // names, one space
inline constexpr std::string_view kLauncherFolder = "launcher.folder";
inline constexpr std::string_view kLaunchPrefix = "components.";
// The fields of components.<c>.
inline constexpr std::string_view kLaunchReqState = "reqState";
inline constexpr std::string_view kLaunchCurrState = "currState";
inline constexpr std::string_view kLaunchStatus = "status";
inline constexpr std::string_view kLaunchPid = "pid";
inline constexpr std::string_view kLaunchExitCode = "exitCode";
inline constexpr std::string_view kLaunchRestarts = "restarts";
inline constexpr std::string_view kLaunchStdout = "stdout";
inline constexpr std::string_view kLaunchStderr = "stderr";
inline constexpr std::string_view kLaunchPeisName = "peisName";
inline constexpr std::string_view kLaunchExecutable = "executable";
inline constexpr std::string_view kLaunchFile = "file";
inline constexpr std::string_view kLaunchDescriptor = "descriptor";
// Values of components.<c>.currState (reqState takes `on` and `off`).
inline constexpr std::string_view kLaunchOff = "off";
inline constexpr std::string_view kLaunchStarting = "starting";
inline constexpr std::string_view kLaunchOn = "on";
inline constexpr std::string_view kLaunchStopping = "stopping";
inline constexpr std::string_view kLaunchRestarting =
    "restarting";  // crashed, waiting out a back-off
inline constexpr std::string_view kLaunchFailed = "failed";

// "tracker", "reqState" -> "components.tracker.reqState".
inline std::string launchKey(std::string_view component, std::string_view field) {
  return std::string(kLaunchPrefix) + std::string(component) + "." + std::string(field);
}
// "tracker" -> "components.tracker": the component's actuator name.
inline std::string launchActuator(std::string_view component) {
  return std::string(kLaunchPrefix) + std::string(component);
}
// "components.tracker.reqState" -> {"tracker", "reqState"}; nothing for any
// other key (the component name is one key part, the field one more).
inline std::optional<std::pair<std::string, std::string>> parseLaunchKey(std::string_view key) {
  if (key.substr(0, kLaunchPrefix.size()) != kLaunchPrefix) return std::nullopt;
  const auto rest = key.substr(kLaunchPrefix.size());
  const auto dot = rest.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 >= rest.size()) return std::nullopt;
  const auto field = rest.substr(dot + 1);
  if (field.find('.') != std::string_view::npos) return std::nullopt;
  return std::make_pair(std::string(rest.substr(0, dot)), std::string(field));
}

}  // namespace peis::conventions

namespace peis {
using conventions::metaInputKey;
}  // namespace peis
