// From a scenario to its processes; see launch_plan.h.
#include "launch_plan.h"

#include <algorithm>
#include <filesystem>
#include <regex>

#include "program_finder.h"

namespace peis::scenario {
namespace {

constexpr const char* kEmulatorTool = "simavr_uart_socket";

std::string number(double value) {
  std::string text = std::to_string(value);
  text.erase(text.find_last_not_of('0') + 1);
  if (!text.empty() && text.back() == '.') text.pop_back();
  return text;
}

void addPeisFlags(Launch& launch, const std::string& name, const std::optional<long long>& id,
                  const RunContext& context) {
  launch.argv.insert(launch.argv.end(), {"--peis-name", name});
  if (id) launch.argv.insert(launch.argv.end(), {"--peis-id", std::to_string(*id)});
  launch.argv.insert(launch.argv.end(), {"--peis-ecology", context.ecology});
}

// The simulated medium's knobs, and the file that cuts this member off it.
void addRadioEnvironment(Launch& launch, const Scenario& scenario, const RunContext& context) {
  launch.env.emplace_back("TINY_MEDIUM_PORT", std::to_string(context.radioPort));
  if (scenario.radio) {
    launch.env.emplace_back("TINY_LOSS", std::to_string(scenario.radio->lossPercent));
    launch.env.emplace_back("TINY_DELAY_MS", std::to_string(scenario.radio->delayMs));
    launch.env.emplace_back("TINY_JITTER_MS", std::to_string(scenario.radio->jitterMs));
  }
  launch.radioControl = context.dir + "/" + launch.label + ".radio-cut";
  launch.env.emplace_back("TINY_RADIO_CUT_FILE", launch.radioControl);
}

}  // namespace

std::string scenarioDirectory(const Scenario& scenario) {
  const auto parent = std::filesystem::path(scenario.path).parent_path();
  return parent.empty() ? "." : parent.string();
}

std::string substitute(const std::string& text, const Scenario& scenario, const RunContext& context,
                       const std::function<void(const std::string&)>& error) {
  static const std::regex placeholder(R"(\{([a-z][a-z-]*)\})");
  std::string out;
  auto begin = std::sregex_iterator(text.begin(), text.end(), placeholder);
  std::size_t last = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    const auto& m = *it;
    out += text.substr(last, static_cast<std::size_t>(m.position()) - last);
    last = static_cast<std::size_t>(m.position() + m.length());
    const std::string name = m[1];
    if (name == "here")
      out += scenarioDirectory(scenario);
    else if (name == "dir")
      out += context.dir;
    else if (name == "radio")
      out += "medium:" + std::to_string(context.radioPort);
    else if (name == "radio-port")
      out += std::to_string(context.radioPort);
    else if (name == "speed")
      out += number(context.speed);
    else if (name == "ecology")
      out += context.ecology;
    else if (name == "world")
      out += scenario.world ? scenario.world->name : "world";
    else {
      error("unknown placeholder {" + name +
            "} (known: {here}, {dir}, {radio}, {radio-port}, {speed}, {ecology}, {world})");
      out += m.str();
    }
  }
  return out + text.substr(last);
}

TinyTarget resolveTarget(const PeisSpec& peis, const ProgramFinder& finder) {
  if (peis.on != TinyTarget::Auto) return peis.on;
  const bool emulator = finder.find(kEmulatorTool) && finder.firmware("avr", peis.tiny);
  return emulator ? TinyTarget::Avr : TinyTarget::Host;
}

LaunchPlan planLaunches(const Scenario& scenario, const RunContext& context,
                        const ProgramFinder& finder, const std::vector<std::string>& without) {
  LaunchPlan plan;
  auto at = [&](const Origin& origin) {
    return [&plan, origin](const std::string& why) {
      plan.errors.push_back(origin.str() + ": " + why);
    };
  };
  auto program = [&](const std::string& name, const Origin& origin) -> std::string {
    if (const auto path = finder.find(name)) return *path;
    plan.errors.push_back(origin.str() + ": unknown program '" + name +
                          "' (looked in: " + finder.searched() + ")");
    return name;
  };
  auto left = [&](const std::string& name) {
    return std::find(without.begin(), without.end(), name) != without.end();
  };

  if (scenario.world && !left(scenario.world->name)) {
    const auto& w = *scenario.world;
    Launch launch;
    launch.peis = launch.label = w.name;
    launch.role = LaunchRole::World;
    launch.program = "peis-sim-world";
    launch.argv.push_back(program("peis-sim-world", w.origin));
    if (!w.file.empty())
      launch.argv.insert(launch.argv.end(),
                         {"--world", substitute(w.file, scenario, context, at(w.origin))});
    launch.argv.insert(launch.argv.end(), {"--speed", number(context.speed), "--picture",
                                           context.dir + "/world-at-exit.png"});
    for (const auto& o : w.options)
      launch.argv.push_back(substitute(o, scenario, context, at(w.origin)));
    addPeisFlags(launch, w.name, std::nullopt, context);
    launch.joinNames.push_back(w.name);
    launch.joinNames.insert(launch.joinNames.end(), w.hosts.begin(), w.hosts.end());
    plan.launches.push_back(std::move(launch));
  }

  bool needGatewayKeys = false;
  for (const auto& p : scenario.peis) {
    if (left(p.name)) continue;
    auto error = at(p.origin);
    std::vector<std::pair<std::string, std::string>> env;
    for (const auto& [name, value] : p.env)
      env.emplace_back(name, substitute(value, scenario, context, error));
    if (!p.isTiny()) {
      Launch launch;
      launch.peis = launch.label = p.name;
      launch.program = p.program;
      launch.argv.push_back(program(p.program, p.origin));
      bool onRadio = false;
      for (const auto& o : p.options) {
        onRadio = onRadio || o.find("{radio") != std::string::npos;
        launch.argv.push_back(substitute(o, scenario, context, error));
      }
      addPeisFlags(launch, p.name, p.id, context);
      launch.env = env;
      if (onRadio) addRadioEnvironment(launch, scenario, context);
      launch.joinNames.push_back(p.name);
      launch.joinNames.insert(launch.joinNames.end(), p.hosts.begin(), p.hosts.end());
      plan.launches.push_back(std::move(launch));
      continue;
    }
    if (!p.id) {
      error("tiny node '" + p.name + "' needs id: (the node id it uses on the radio)");
      continue;
    }
    const TinyTarget target = resolveTarget(p, finder);
    if (target == TinyTarget::Host) {
      Launch launch;
      launch.peis = launch.label = p.name;
      launch.role = LaunchRole::TinyHost;
      launch.program = "tiny-" + p.tiny;
      launch.argv = {program("tiny-" + p.tiny, p.origin), "--id", std::to_string(*p.id)};
      launch.env = env;
      addRadioEnvironment(launch, scenario, context);
      launch.joinId = p.id;
      plan.launches.push_back(std::move(launch));
      continue;
    }
    // On the emulated ATmega128: the emulator, then its gateway.
    needGatewayKeys = true;
    const auto firmware = finder.firmware("avr", p.tiny);
    if (!firmware)
      error("tiny node '" + p.name + "' on: avr needs the ATmega128 firmware " + p.tiny +
            ".elf (gcc-avr and avr-libc when configuring: ./run installs them)");
    const std::string socket = context.dir + "/" + p.name + ".uart";
    Launch emulator;
    emulator.peis = emulator.label = p.name;
    emulator.role = LaunchRole::Emulator;
    emulator.program = kEmulatorTool;
    const auto tool = finder.find(kEmulatorTool);
    if (!tool)
      error("tiny node '" + p.name + "' on: avr needs the simavr_uart_socket tool (libsimavr-dev)");
    // Paced to real time; it runs until the runner stops it (a day at most).
    emulator.argv = {tool.value_or(kEmulatorTool),
                     "--socket",
                     socket,
                     "--mcu",
                     "atmega128",
                     "--freq",
                     "16000000",
                     "--time-limit",
                     "86400",
                     firmware.value_or(p.tiny + ".elf")};
    emulator.env = env;
    emulator.joinId = p.id;
    plan.launches.push_back(std::move(emulator));
    Launch gateway;
    gateway.peis = p.name;
    gateway.label = p.name + "-gateway";
    gateway.role = LaunchRole::Gateway;
    gateway.program = "peis-tinybridge";
    gateway.argv = {program("peis-tinybridge", p.origin), "--link", "unix:" + socket, "--registry",
                    context.dir + "/" + gateway.label + ".sqlite"};
    if (scenario.radio && !scenario.radio->keys.empty())
      gateway.argv.insert(gateway.argv.end(),
                          {"--keys", substitute(scenario.radio->keys, scenario, context,
                                                at(scenario.radio->origin))});
    addPeisFlags(gateway, gateway.label, std::nullopt, context);
    gateway.joinNames.push_back(gateway.label);
    plan.launches.push_back(std::move(gateway));
  }
  if (needGatewayKeys && (!scenario.radio || scenario.radio->keys.empty()))
    plan.errors.push_back(scenario.origin.str() +
                          ": tiny nodes on the emulated MCU reach the ecology through a gateway "
                          "tinybridge, which needs the key registry seed: radio: {keys: FILE}");
  return plan;
}

}  // namespace peis::scenario
