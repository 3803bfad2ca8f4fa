// Component conventions on top of the public Kernel API only.
#include "peis/component.h"

#include <map>
#include <mutex>

#include "peis/error.h"

namespace peis {
namespace {

constexpr std::chrono::milliseconds kFreshnessCheck{50};

std::string joined(const std::vector<std::string>& items) {
  std::string text;
  for (const auto& item : items) text += (text.empty() ? "" : " ") + item;
  return text;
}

}  // namespace

const char* toString(ComponentStatus status) {
  switch (status) {
    case ComponentStatus::Initializing:
      return "initializing";
    case ComponentStatus::Waiting:
      return "waiting";
    case ComponentStatus::Running:
      return "running";
    case ComponentStatus::Error:
      return "error";
  }
  return "error";
}

struct Component::State {
  struct Input {
    std::chrono::milliseconds freshness{0};
    std::optional<Tuple> value;
    std::chrono::steady_clock::time_point arrival;
    TupleCallback onValue;
  };
  Kernel* kernel = nullptr;
  std::string name;
  mutable std::mutex mu;
  std::map<std::string, Input> inputs;
  std::map<std::string, Apply> actuators;
  std::vector<CallbackHandle> callbacks;
  std::optional<TimerHandle> freshnessTimer;
  bool started = false;
  std::optional<std::string> errorCause;
  std::optional<ComponentStatus> published;
  std::string publishedCauses;

  bool fresh(const Input& input) const {
    if (!input.value) return false;
    if (input.freshness.count() <= 0) return true;
    return std::chrono::steady_clock::now() - input.arrival <= input.freshness;
  }

  std::vector<std::string> missing() const {
    std::vector<std::string> names;
    for (const auto& [inputName, input] : inputs) {
      if (!fresh(input)) names.push_back(inputName);
    }
    return names;
  }

  ComponentStatus compute(std::string& causes) const {
    if (errorCause) {
      causes = *errorCause;
      return ComponentStatus::Error;
    }
    if (!started) {
      causes.clear();
      return ComponentStatus::Initializing;
    }
    causes = joined(missing());
    return causes.empty() ? ComponentStatus::Running : ComponentStatus::Waiting;
  }

  // Writes status and cause.names when they changed. mu held.
  void publish() {
    std::string causes;
    const auto status = compute(causes);
    if (published == status && publishedCauses == causes) return;
    kernel->set(conventions::kCauseNames, causes);
    kernel->set(conventions::kStatus, toString(status));
    published = status;
    publishedCauses = causes;
  }
};

Component::Component(Kernel& kernel, std::string name)
    : kernel_(kernel), state_(std::make_shared<State>()) {
  validateName(name);
  state_->kernel = &kernel;
  state_->name = std::move(name);
  kernel_.set(conventions::kComponentName, state_->name);
  std::lock_guard lock(state_->mu);
  state_->publish();
}

Component::Component(Kernel& kernel, std::string name, const Descriptor& descriptor)
    : Component(kernel, std::move(name)) {
  publishDescriptor(descriptor);
}

Component::~Component() {
  std::vector<CallbackHandle> callbacks;
  std::optional<TimerHandle> timer;
  {
    std::lock_guard lock(state_->mu);
    callbacks.swap(state_->callbacks);
    timer = state_->freshnessTimer;
  }
  for (auto handle : callbacks) kernel_.removeCallback(handle);
  if (timer) kernel_.cancelTimer(*timer);
}

void Component::publishDescriptor(const Descriptor& descriptor) {
  std::string names;
  for (const auto& f : descriptor.functionalities) {
    using conventions::functionalityKey;
    kernel_.set(functionalityKey(f.name, "inputs"), formatPorts(f.inputs));
    kernel_.set(functionalityKey(f.name, "outputs"), formatPorts(f.outputs));
    kernel_.set(functionalityKey(f.name, "preconditions"), joined(f.preconditions));
    kernel_.set(functionalityKey(f.name, "cost"), std::to_string(f.cost));
    if (!f.description.empty()) kernel_.set(functionalityKey(f.name, "description"), f.description);
    if (!f.activation.empty()) kernel_.set(functionalityKey(f.name, "activation"), f.activation);
    names += (names.empty() ? "" : " ") + f.name;
  }
  kernel_.set(conventions::kFunctionalities, names);
  WriteOptions yaml;
  yaml.mimetype = "application/yaml";
  kernel_.set(conventions::kComponentDescriptor, descriptor.toYaml(), yaml);
}

void Component::input(const std::string& name, std::chrono::milliseconds freshness,
                      TupleCallback onValue) {
  const auto metaKey = metaInputKey(name);
  validateKey(metaKey);
  auto state = state_;
  {
    std::lock_guard lock(state->mu);
    if (state->inputs.count(name)) {
      throw Error(ErrorCode::InvalidArgument, "input '" + name + "' is declared twice");
    }
    state->inputs[name] = State::Input{freshness, std::nullopt, {}, std::move(onValue)};
    if (freshness.count() > 0 && !state->freshnessTimer) {
      state->freshnessTimer = kernel_.every(kFreshnessCheck, [state] {
        std::lock_guard lock(state->mu);
        state->publish();
      });
    }
  }
  kernel_.declareMeta(metaKey);
  // Re-pointing forgets the old producer's value before the new one arrives.
  auto repointed =
      kernel_.onChange(Pattern::exact(kernel_.id(), metaKey), [state, name](const Tuple&) {
        std::lock_guard lock(state->mu);
        auto& input = state->inputs[name];
        const auto target = state->kernel->resolveMeta(state->kernel->id(), metaInputKey(name));
        if (input.value &&
            (!target || target->owner != input.value->owner || target->key != input.value->key)) {
          input.value.reset();
          state->publish();
        }
      });
  auto values = kernel_.subscribeIndirect(kernel_.id(), metaKey, [state, name](const Tuple& t) {
    TupleCallback onValue;
    {
      std::lock_guard lock(state->mu);
      auto& input = state->inputs[name];
      input.value = t;
      input.arrival = std::chrono::steady_clock::now();
      onValue = input.onValue;
      state->publish();
    }
    if (onValue) onValue(t);
  });
  std::lock_guard lock(state->mu);
  state->callbacks.push_back(repointed);
  state->callbacks.push_back(values);
  state->publish();
}

std::optional<Tuple> Component::inputValue(const std::string& name) const {
  std::lock_guard lock(state_->mu);
  auto it = state_->inputs.find(name);
  if (it == state_->inputs.end()) {
    throw Error(ErrorCode::NotFound, "component " + state_->name + " has no input '" + name + "'");
  }
  return it->second.value;
}

bool Component::inputFresh(const std::string& name) const {
  std::lock_guard lock(state_->mu);
  auto it = state_->inputs.find(name);
  return it != state_->inputs.end() && state_->fresh(it->second);
}

void Component::actuator(const std::string& name, Apply apply, std::string initialState) {
  const auto reqKey = conventions::reqStateKey(name);
  validateKey(reqKey);
  {
    std::lock_guard lock(state_->mu);
    if (state_->actuators.count(name)) {
      throw Error(ErrorCode::InvalidArgument, "actuator '" + name + "' is declared twice");
    }
    state_->actuators[name] = std::move(apply);
  }
  kernel_.set(conventions::currStateKey(name), std::move(initialState));
  kernel_.set(conventions::actuatorStatusKey(name), std::string(conventions::kActuatorOk));
  auto state = state_;
  auto handle = kernel_.onChange(Pattern::exact(kernel_.id(), reqKey), [state,
                                                                        name](const Tuple& t) {
    Apply fn;
    {
      std::lock_guard lock(state->mu);
      fn = state->actuators[name];
    }
    state->kernel->set(conventions::actuatorStatusKey(name),
                       std::string(conventions::kActuatorBusy));
    try {
      auto reached = fn(t.data);
      state->kernel->set(conventions::currStateKey(name), std::move(reached));
      state->kernel->set(conventions::actuatorStatusKey(name),
                         std::string(conventions::kActuatorOk));
    } catch (const std::exception& e) {
      state->kernel->set(conventions::actuatorStatusKey(name), std::string("error: ") + e.what());
    }
  });
  std::lock_guard lock(state_->mu);
  state_->callbacks.push_back(handle);
  // A request that was there before the actuator existed (--peis-set-tuple).
  if (auto pending = kernel_.get(reqKey)) {
    kernel_.set(reqKey, pending->data, WriteOptions{pending->mimetype, pending->encoding});
  }
}

void Component::setActuatorState(const std::string& name, std::string currState,
                                 std::string status) {
  kernel_.set(conventions::currStateKey(name), std::move(currState));
  kernel_.set(conventions::actuatorStatusKey(name), std::move(status));
}

void Component::start() {
  std::lock_guard lock(state_->mu);
  state_->started = true;
  state_->errorCause.reset();
  state_->publish();
}

void Component::fail(const std::string& cause) {
  std::lock_guard lock(state_->mu);
  state_->errorCause = cause;
  state_->publish();
}

ComponentStatus Component::status() const {
  std::lock_guard lock(state_->mu);
  std::string causes;
  return state_->compute(causes);
}

std::vector<std::string> Component::missingInputs() const {
  std::lock_guard lock(state_->mu);
  return state_->missing();
}

const std::string& Component::name() const { return state_->name; }

}  // namespace peis
