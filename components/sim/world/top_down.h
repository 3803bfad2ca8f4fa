// The top-down picture of a simulated home (PNG), so a person can see what
// happened: rooms shaded by the light, walls, windows and blinds, furniture,
// lamps, objects, people, the cameras' fields of view on the floor, each
// robot's true pose and path, and every estimate and planned path the world
// has heard of (docs/components/sim-world.md, "The top-down picture").
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "sim/world/light_model.h"
#include "sim/world/simulation.h"

namespace peis::sim {

// A pose some PEIS estimated for a robot (a `position.<robot>` tuple).
struct Estimate {
  std::string robot;
  std::string by;  // who estimated it (a PEIS name or id)
  Vec2 position;
  std::vector<Vec2> trail;
};

// A path some PEIS planned for a robot (a `path.<robot>` tuple).
struct PlannedPath {
  std::string robot;
  std::string by;
  std::vector<Vec2> points;
};

struct TopDownOptions {
  double pixelsPerMetre = 100;
  std::string caption;  // drawn at the top, e.g. the simulated time
};

// The picture as PNG bytes.
std::string renderTopDown(const Simulation& simulation, const LightModel& light,
                          const std::vector<Estimate>& estimates,
                          const std::vector<PlannedPath>& paths, const TopDownOptions& options);

// The floor polygon a camera sees (the image border projected onto z = 0,
// cut at `maxRange` metres from the camera); empty if it sees no floor.
Polygon fieldOfView(const camera::Calibration& calibration, double maxRange = 30);

}  // namespace peis::sim
