// Component: a helper that implements the component conventions every
// PEIS-component follows so the meta-level can plan with it and watch it
// (docs/components.md; the key names are in peis/conventions.h). Part of the
// component library (peis::component), written against the kernel's public
// API only:
//   status       initializing | waiting | running | error
//   cause.names  the inputs that are missing or stale while waiting (or the
//                error's cause), space-separated
//   mi-<input>   meta tuples a configurator points at producers
//   component.outputs  the keys it writes, declared with output()
//   <act>.reqState / <act>.currState / <act>.status   for each actuator
//   component.*, functionalities, functionality.<f>.*  the descriptor
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "peis/conventions.h"
#include "peis/descriptor.h"
#include "peis/kernel.h"

namespace peis {

enum class ComponentStatus { Initializing, Waiting, Running, Error };
const char* toString(ComponentStatus status);

class Component {
 public:
  // Publishes status = initializing (and the descriptor, when given).
  Component(Kernel& kernel, std::string name);
  Component(Kernel& kernel, std::string name, const Descriptor& descriptor);
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;
  ~Component();

  // An input fed through meta tuple mi-<name>. With a positive `freshness`,
  // a value older than that counts as missing. `onValue` runs on the kernel
  // thread for every new value.
  void input(const std::string& name, std::chrono::milliseconds freshness = {},
             TupleCallback onValue = {});
  std::optional<Tuple> inputValue(const std::string& name) const;
  bool inputFresh(const std::string& name) const;

  // An output: a key of this PEIS the component writes, listed in
  // component.outputs so that tools and the meta-level see what it
  // produces. `options` apply to every write (a mimetype; a ttl makes the
  // value expire when the component stops writing). InvalidKey,
  // InvalidArgument (declared twice).
  void output(const std::string& name, WriteOptions options = {});
  // Writes a declared output; returns the tuple as stamped. NotFound for an
  // output that was not declared (a typo would otherwise create a key no
  // consumer reads).
  Tuple write(const std::string& output, std::string data);
  // The declared outputs, sorted.
  std::vector<std::string> outputs() const;

  // An actuator: writes to <name>.reqState call `apply` on the kernel thread;
  // what it returns becomes <name>.currState, and <name>.status becomes
  // "ok" (or "error: ..." if it throws).
  using Apply = std::function<std::string(const std::string& requested)>;
  void actuator(const std::string& name, Apply apply, std::string initialState = "");
  // For actuators that finish later: report the state reached.
  void setActuatorState(const std::string& name, std::string currState, std::string status = "ok");

  // Called on the kernel thread after each change of status or cause.names,
  // in order, with the new values; e.g. an actuator goes to a safe state
  // when an input goes stale. Only changes after this call are reported.
  // One callback per component; an empty function removes it.
  using StatusCallback = std::function<void(ComponentStatus status, const std::string& causes)>;
  void onStatusChange(StatusCallback fn);

  // Initialisation is over: status follows the inputs from now on
  // (running when all are present and fresh, waiting otherwise).
  void start();
  // Puts the component in error with a cause until start() is called again.
  void fail(const std::string& cause);
  ComponentStatus status() const;
  std::vector<std::string> missingInputs() const;
  const std::string& name() const;
  Kernel& kernel() { return kernel_; }

 private:
  struct State;
  void publishDescriptor(const Descriptor& descriptor);
  Kernel& kernel_;
  std::shared_ptr<State> state_;
};

}  // namespace peis
