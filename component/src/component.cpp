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
  std::map<std::string, WriteOptions> outputs;
  StatusCallback onStatus;
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

  // Writes status and cause.names when they changed, and tells the status
  // callback (queued on the kernel thread, so it runs without mu and in
  // order). mu held.
  void publish(const std::shared_ptr<State>& self) {
    std::string causes;
    const auto status = compute(causes);
    if (published == status && publishedCauses == causes) return;
    kernel->set(conventions::kCauseNames, causes);
    kernel->set(conventions::kStatus, toString(status));
    published = status;
    publishedCauses = causes;
    if (onStatus) {
      std::weak_ptr<State> weak = self;
      kernel->post([weak, status, causes] {
        auto state = weak.lock();
        if (!state) return;
        StatusCallback fn;
        {
          std::lock_guard lock(state->mu);
          fn = state->onStatus;
        }
        if (fn) fn(status, causes);
      });
    }
  }
};

Component::Component(Kernel& kernel, std::string name)
    : kernel_(kernel), state_(std::make_shared<State>()) {
  validateName(name);
  state_->kernel = &kernel;
  state_->name = std::move(name);
  kernel_.set(conventions::kComponentName, state_->name);
  std::lock_guard lock(state_->mu);
  state_->publish(state_);
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
  {
    std::lock_guard lock(state_->mu);
    state_->onStatus = nullptr;  // status changes queued already are not reported
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
        state->publish(state);
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
          state->publish(state);
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
      state->publish(state);
    }
    if (onValue) onValue(t);
  });
  std::lock_guard lock(state->mu);
  state->callbacks.push_back(repointed);
  state->callbacks.push_back(values);
  state->publish(state);
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

void Component::output(const std::string& name, WriteOptions options) {
  validateKey(name);
  if (options.mimetype.size() > kMaxMimetypeBytes) {
    throw Error(ErrorCode::InvalidArgument, "output '" + name + "': mimetype too long");
  }
  std::string list;
  {
    std::lock_guard lock(state_->mu);
    if (state_->outputs.count(name)) {
      throw Error(ErrorCode::InvalidArgument, "output '" + name + "' is declared twice");
    }
    state_->outputs[name] = std::move(options);
    for (const auto& [each, unused] : state_->outputs) list += (list.empty() ? "" : " ") + each;
  }
  kernel_.set(conventions::kComponentOutputs, std::move(list));
}

Tuple Component::write(const std::string& output, std::string data) {
  WriteOptions options;
  {
    std::lock_guard lock(state_->mu);
    auto it = state_->outputs.find(output);
    if (it == state_->outputs.end()) {
      throw Error(ErrorCode::NotFound,
                  "component " + state_->name + " has no output '" + output + "'");
    }
    options = it->second;
  }
  return kernel_.set(output, std::move(data), options);
}

std::vector<std::string> Component::outputs() const {
  std::lock_guard lock(state_->mu);
  std::vector<std::string> names;
  for (const auto& [name, unused] : state_->outputs) names.push_back(name);
  return names;
}

void Component::onStatusChange(StatusCallback fn) {
  std::lock_guard lock(state_->mu);
  state_->onStatus = std::move(fn);
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
  state_->publish(state_);
}

void Component::fail(const std::string& cause) {
  std::lock_guard lock(state_->mu);
  state_->errorCause = cause;
  state_->publish(state_);
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
