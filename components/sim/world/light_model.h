// LightModel: how bright it is at a point of the home (docs/components/
// sim-world.md, "The light model"). Daylight enters through each window, a
// Lambertian area source attenuated by the window's blind; each lamp is a
// point source; walls block both; an ambient term adds a little everywhere.
// The result is the illuminance in lux on a horizontal surface at height z.
// The model is linear in the daylight, the blind openings and the lamp
// levels, so per-window and per-lamp floor maps are computed once and the
// cameras shade whole images from them cheaply.
#pragma once

#include <vector>

#include "sim/world/world.h"

namespace peis::sim {

// What changes the light while the simulation runs.
struct LightState {
  double daylightLux = 0;
  std::vector<double> blindTilt;  // per window (0 closed .. 100 open), in World::windows order
  std::vector<double> lampLevel;  // per lamp (0..100), in World::lamps order
  bool operator==(const LightState&) const = default;
};

// The state the world file starts with.
LightState initialLightState(const World& world);
// The fraction of daylight a blind lets through: 0.05 closed .. 1 open.
double blindOpening(double tilt);

class LightModel {
 public:
  // Precomputes the floor maps at `mapResolution` metres per cell.
  explicit LightModel(const World& world, double mapResolution = 0.1);

  // Exact: illuminance (lux) on a horizontal surface at (p, z).
  double illuminance(const LightState& state, Vec2 p, double z) const;
  // From the floor maps (bilinear), z = 0; outside the map: ambient only.
  double floorIlluminance(const LightState& state, Vec2 p) const;

  // The terms alone, direct plus bounced: lux per lux of daylight with the
  // blind open, and lux of a lamp at level 100.
  double windowTerm(std::size_t window, Vec2 p, double z) const;
  double lampTerm(std::size_t lamp, Vec2 p, double z) const;
  // The direct parts only (what walls block).
  double directWindowTerm(std::size_t window, Vec2 p, double z) const;
  double directLampTerm(std::size_t lamp, Vec2 p, double z) const;
  // The bounced light of a source in the room holding p (0 outside rooms).
  double bouncedWindowTerm(std::size_t window, Vec2 p) const;
  double bouncedLampTerm(std::size_t lamp, Vec2 p) const;

 private:
  struct Source {
    Vec2 a, b;    // the window's ends
    Vec2 inward;  // unit normal into the home
    double sill, top;
  };
  bool blocked(Vec2 from, Vec2 to, const Source* through) const;
  double mapValue(const std::vector<float>& map, Vec2 p) const;
  // Per source, per room: the mean direct floor illuminance times the bounce factor.
  std::vector<double> bounced(const std::vector<float>& directMap) const;
  double bouncedIn(const std::vector<double>& perRoom, Vec2 p) const;

  const World* world_;
  std::vector<Source> windows_;
  std::vector<std::pair<Vec2, Vec2>> wallSegments_;  // centre lines
  double cell_;
  int columns_, rows_;
  std::vector<std::vector<float>> windowMaps_, lampMaps_;  // direct + bounced
  std::vector<std::vector<double>> windowBounce_, lampBounce_;
};

}  // namespace peis::sim
