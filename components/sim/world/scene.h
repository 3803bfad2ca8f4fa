// Scene: the physics.scene tuple — everything that moves or changes the
// light at one instant — and its text form (docs/components/sim-world.md,
// "physics.scene"). The world writes it; the simulated cameras read it.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "sim/world/light_model.h"
#include "sim/world/simulation.h"

namespace peis::sim {

struct Scene {
  struct Named {
    std::string name;
    Pose2 pose;
    bool operator==(const Named&) const = default;
  };
  double time = 0;
  double daylightLux = 0;
  std::vector<std::pair<std::string, double>> blinds;  // name, tilt
  std::vector<std::pair<std::string, double>> lamps;   // name, level
  std::vector<Named> robots;
  std::vector<Named> objects;
  std::vector<std::pair<std::string, std::string>> people;  // name, state
  bool operator==(const Scene&) const = default;
};

Scene sceneOf(const Simulation& simulation);
std::string formatScene(const Scene& scene);
// Throws std::invalid_argument naming the line for a malformed known line;
// lines of unknown kinds are skipped (the format grows).
Scene parseScene(std::string_view text);
// The light state a scene describes, in the world's window and lamp order
// (items the scene does not name keep the world file's values).
LightState lightStateOf(const World& world, const Scene& scene);

}  // namespace peis::sim
