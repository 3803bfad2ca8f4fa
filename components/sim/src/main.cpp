// peis-sim-world: the simulated PEIS-Home as a PEIS (docs/components/
// sim-world.md): ground truth, robot drivers, map server and physics
// channel on a simulated clock.
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

#include "common/command_line.h"
#include "peis/error.h"
#include "peis/options.h"
#include "world_node.h"

namespace {

const char* kUsage =
    "Usage: peis-sim-world [--world FILE] [options]\n"
    "\n"
    "The simulated home: runs the world of FILE on a simulated clock, hosts a driver\n"
    "PEIS per robot (VelCommand, TalkCommand in; Odometry, SonarRange, Bumper,\n"
    "Battery out), serves the map and named places, publishes the physics channel\n"
    "for simulated sensors and draws a top-down picture. See docs/components/sim-world.md.\n"
    "\n"
    "  --world FILE         the world file (default: the PEIS-Home, installed in\n"
    "                       share/peis/homes/ or else " PEIS_SIM_DEFAULT_WORLD
    ")\n"
    "  --speed S            simulated seconds per real second, 0.1..100 (default 1)\n"
    "  --tick-ms N          physics step in ms of simulated time, 1..100 (default 10)\n"
    "  --duration SECONDS   end after this much simulated time (default: run until told)\n"
    "  --scene-hz HZ        rate of physics.scene in simulated time, 1..200 (default 20)\n"
    "  --seed N             seed of the sensor noise (default 1)\n"
    "  --picture FILE       top-down picture written at the end (default sim-world.png;\n"
    "                       an empty FILE writes none)\n"
    "  --picture-scale PX   pixels per metre of the picture, 10..400 (default 100)\n"
    "  --bind KEY=OWNER.KEY a physics input follows another PEIS's tuple, e.g.\n"
    "                       --bind physics.lamp.lamp.level=7.LampLevel (repeatable)\n"
    "  --help               this text\n"
    "\n"
    "The world PEIS is named 'world' unless --peis-name says otherwise.\n";

// The PEIS-Home installed beside the program (<prefix>/share/peis/homes/),
// else the one of the source tree the program was built from.
std::string defaultWorld() {
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const auto installed = self.parent_path() / PEIS_SIM_INSTALLED_WORLD;
    if (std::filesystem::exists(installed, error)) return installed.lexically_normal().string();
  }
  return PEIS_SIM_DEFAULT_WORLD;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace peis::components;
  peis::sim::WorldConfig config;
  std::string worldPath = defaultWorld();
  if (auto done = parsePeisOptions(argc, argv, "peis-sim-world", kUsage, "world", config.peis))
    return *done;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const char* value = i + 1 < argc ? argv[i + 1] : nullptr;
    double n = 0;
    auto bad = [&](const std::string& why) { return badArgument("peis-sim-world", arg, why); };
    if (arg == "--world" && value != nullptr) {
      worldPath = value;
    } else if (arg == "--speed" && value != nullptr) {
      if (!parseNumber(value, 0.1, 100, &config.speed)) return bad("takes 0.1..100");
    } else if (arg == "--tick-ms" && value != nullptr) {
      if (!parseNumber(value, 1, 100, &n)) return bad("takes 1..100");
      config.tick = n / 1000;
    } else if (arg == "--duration" && value != nullptr) {
      if (!parseNumber(value, 0.001, 1e7, &n)) return bad("takes seconds > 0");
      config.duration = n;
    } else if (arg == "--scene-hz" && value != nullptr) {
      if (!parseNumber(value, 1, 200, &config.sceneHz)) return bad("takes 1..200");
    } else if (arg == "--seed" && value != nullptr) {
      if (!parseNumber(value, 0, 4294967295.0, &n) ||
          n != static_cast<double>(static_cast<std::uint32_t>(n)))
        return bad("takes an integer 0..4294967295");
      config.seed = static_cast<std::uint32_t>(n);
    } else if (arg == "--picture" && value != nullptr) {
      config.picturePath = value;
    } else if (arg == "--picture-scale" && value != nullptr) {
      if (!parseNumber(value, 10, 400, &config.pictureScale)) return bad("takes 10..400");
    } else if (arg == "--bind" && value != nullptr) {
      const std::string binding = value;
      const auto eq = binding.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == binding.size())
        return bad("takes PHYSICS-KEY=OWNER.KEY");
      config.bindings.emplace_back(binding.substr(0, eq), binding.substr(eq + 1));
    } else {
      return bad(unknownArgument(arg, value));
    }
    ++i;
  }
  try {
    peis::sim::World world = peis::sim::loadWorldFile(worldPath);
    peis::sim::WorldNode node(std::move(config), std::move(world));
    std::cerr << "peis-sim-world: PEIS " << node.kernel().id() << " '" << node.kernel().name()
              << "' on port " << node.kernel().port() << std::endl;
    const std::string why = node.run();
    std::cerr << "peis-sim-world: " << why << std::endl;
    return 0;
  } catch (const peis::Error& e) {
    std::cerr << "peis-sim-world: " << e.what() << "\n";
    return 1;
  }
}
