// peis-synthetic: a component that does what its functionality descriptor
// says with made-up data, for trying the configurator without hardware and
// for the meta-level's tests and benchmarks (docs/components/synthetic.md).
// It publishes the descriptor, declares the descriptor's meta inputs (with a
// freshness) and outputs, and, while its status is `running` (every input
// fresh) and the functionality is switched on, writes a counter to each
// output every period. An activation actuator switches functionalities;
// with variables, the requested bindings name the output and input keys.
#include <peis/component.h>
#include <peis/options.h>

#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "execution/program_options.h"

namespace {

const char* kUsage = R"usage(Usage: peis-synthetic --descriptor FILE [OPTIONS] [--peis-* options]

A component that behaves as its functionality descriptor says, with made-up
data: it publishes the descriptor, declares the meta inputs (mi-...) and
outputs, and while every input is fresh and the functionality is switched on
(its activation actuator, if it has one) writes a counter to each output every
period.

Options:
  --descriptor FILE    the functionality descriptor (YAML), required
  --period-ms N        how often outputs are written (default 100)
  --freshness-ms N     an input older than this is stale (default 1000)
  --ttl-ms N           outputs expire this long after each write (default: never)
  --silent KEY         declare this output but never write it (repeatable)
  --fact ATOM          publish the fact ATOM, e.g. "in-view(vac,cam1)" (repeatable)
  --error-after-ms N   put the component in `error` N ms after start
  --help               this text
)usage";

struct Settings {
  std::string descriptorPath;
  long periodMs = 100, freshnessMs = 1000, ttlMs = 0, errorAfterMs = -1;
  std::set<std::string> silent;
  std::vector<peis::Term> facts;
};

long whole(const std::string& name, const std::string& value, long low) {
  std::size_t used = 0;
  long number = 0;
  try {
    number = std::stol(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || number < low)
    throw std::invalid_argument(name + " takes a whole number >= " + std::to_string(low));
  return number;
}

// `var=value,var=value` (one instance's binding, as the configurator writes it).
std::map<std::string, std::string> parseBinding(const std::string& text) {
  std::map<std::string, std::string> binding;
  std::istringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    const auto eq = item.find('=');
    if (eq != std::string::npos) binding["?" + item.substr(0, eq)] = item.substr(eq + 1);
  }
  return binding;
}

// `mi-left.?a` with ?a = cam1 -> `mi-left.cam1`; nothing when a variable is unbound.
std::optional<std::string> ground(const std::string& key,
                                  const std::map<std::string, std::string>& binding,
                                  const std::string& self) {
  std::string out;
  std::istringstream in(key);
  for (std::string part; std::getline(in, part, '.');) {
    if (part == "?self") {
      part = self;
    } else if (peis::isVariable(part)) {
      auto it = binding.find(part);
      if (it == binding.end()) return std::nullopt;
      part = it->second;
    }
    out += (out.empty() ? "" : ".") + part;
  }
  return out;
}

struct Synthetic {
  peis::Kernel& kernel;
  Settings settings;
  peis::Descriptor descriptor;
  peis::Component component;
  std::set<std::string> inputs, outputs;
  // Per functionality: its instances' bindings while switched on (one empty
  // binding for "on"); a functionality without activation is always on.
  std::map<std::string, std::vector<std::map<std::string, std::string>>> active;
  long counter = 0;

  Synthetic(peis::Kernel& k, Settings s, peis::Descriptor d)
      : kernel(k),
        settings(std::move(s)),
        descriptor(std::move(d)),
        component(k, descriptor.component, descriptor) {}

  void declareInputs(const std::map<std::string, std::string>& binding) {
    for (const auto& f : descriptor.functionalities) {
      for (const auto& port : f.inputs) {
        const auto key = ground(port.inputKey(), binding, kernel.name());
        if (!key || inputs.count(*key)) continue;
        inputs.insert(*key);
        component.input(key->substr(3), std::chrono::milliseconds(settings.freshnessMs));
      }
    }
  }

  void declareOutputs(const std::map<std::string, std::string>& binding) {
    for (const auto& f : descriptor.functionalities) {
      for (const auto& port : f.outputs) {
        const auto key = ground(port.outputKey(), binding, kernel.name());
        if (!key || outputs.count(*key)) continue;
        outputs.insert(*key);
        peis::WriteOptions options;
        if (settings.ttlMs > 0) options.ttl = std::chrono::milliseconds(settings.ttlMs);
        component.output(*key, options);
      }
    }
  }

  void setUp() {
    declareInputs({});
    declareOutputs({});
    for (const auto& f : descriptor.functionalities) {
      if (f.activation.empty()) {
        active[f.name] = {{}};
        continue;
      }
      active[f.name] = {};
      const std::string actuator = f.activation;
      try {
        component.actuator(actuator, [this, actuator](const std::string& requested) {
          switchTo(actuator, requested);
          return requested;
        });
      } catch (const peis::Error&) {
        // Two functionalities switched by one actuator: declared once.
      }
    }
    for (const auto& fact : settings.facts)
      kernel.set(peis::conventions::factKey(fact.functor, fact.args), "true");
    component.start();
    kernel.every(std::chrono::milliseconds(settings.periodMs), [this] { tick(); });
    if (settings.errorAfterMs >= 0)
      kernel.after(std::chrono::milliseconds(settings.errorAfterMs),
                   [this] { component.fail("synthetic failure (--error-after-ms)"); });
  }

  // On the kernel thread: `<actuator>.reqState` = on | off | bindings.
  void switchTo(const std::string& actuator, const std::string& requested) {
    std::vector<std::map<std::string, std::string>> bindings;
    if (requested == "on") {
      bindings.push_back({});
    } else if (!requested.empty() && requested != "off") {
      std::istringstream in(requested);
      for (std::string item; in >> item;) bindings.push_back(parseBinding(item));
    }
    for (const auto& f : descriptor.functionalities) {
      if (f.activation != actuator) continue;
      active[f.name] = bindings;
    }
    for (const auto& b : bindings) {
      declareInputs(b);
      declareOutputs(b);
    }
  }

  void tick() {
    if (component.status() != peis::ComponentStatus::Running) return;
    ++counter;
    std::set<std::string> written;
    for (const auto& f : descriptor.functionalities) {
      for (const auto& binding : active[f.name]) {
        for (const auto& port : f.outputs) {
          const auto key = ground(port.outputKey(), binding, kernel.name());
          if (!key || settings.silent.count(*key) || !written.insert(*key).second) continue;
          if (!outputs.count(*key)) continue;
          component.write(*key, std::to_string(counter));
        }
      }
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  peis::Options options;
  try {
    options = peis::Options::fromArgs(argc, argv);
  } catch (const peis::Error& e) {
    std::cerr << "peis-synthetic: " << e.what() << "\n";
    return 2;
  }
  Settings settings;
  const int code = peis::exec::parseProgramOptions(
      argc, argv, "peis-synthetic", kUsage,
      [&settings](const std::string& n, const std::string& v) {
        if (n == "--descriptor") {
          settings.descriptorPath = v;
        } else if (n == "--period-ms") {
          settings.periodMs = whole(n, v, 1);
        } else if (n == "--freshness-ms") {
          settings.freshnessMs = whole(n, v, 1);
        } else if (n == "--ttl-ms") {
          settings.ttlMs = whole(n, v, 0);
        } else if (n == "--error-after-ms") {
          settings.errorAfterMs = whole(n, v, 0);
        } else if (n == "--silent") {
          settings.silent.insert(v);
        } else if (n == "--fact") {
          std::string problem;
          auto term = peis::Term::parse(v, &problem);
          if (!term || !term->isGround())
            throw std::invalid_argument("--fact '" + v + "' is not a ground atom " + problem);
          settings.facts.push_back(*term);
        } else {
          return false;
        }
        return true;
      });
  if (code >= 0) return code;
  if (settings.descriptorPath.empty()) {
    std::cerr << "peis-synthetic: --descriptor FILE is required (see --help)\n";
    return 2;
  }
  peis::Descriptor descriptor;
  try {
    descriptor = peis::Descriptor::fromFile(settings.descriptorPath);
  } catch (const peis::Error& e) {
    std::cerr << "peis-synthetic: " << e.what() << "\n";
    return 2;
  }
  peis::Kernel kernel(options);
  Synthetic synthetic(kernel, settings, descriptor);
  synthetic.setUp();
  kernel.run();
  return 0;
}
