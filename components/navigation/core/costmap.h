// The grid navigation plans on: the occupancy grid inflated by the robot's
// radius. A cell is *lethal* when the robot's centre there would put its disk
// (plus a safety margin) over an occupied cell; cells a little further out
// cost more to cross, so paths keep off walls when there is room. Distances
// come from an exact Euclidean distance transform (Felzenszwalb and
// Huttenlocher, linear in the number of cells).
#pragma once

#include <cstdint>
#include <vector>

#include "occupancy_grid.h"

namespace peis::nav {

struct InflationOptions {
  double robotRadius = 0.2;       // metres
  double safetyMargin = 0.02;     // added to the radius: lethal below radius + margin
  double comfortDistance = 0.25;  // beyond the lethal distance, cells cost extra for this far
  double comfortWeight = 2.0;     // at most this much extra per metre travelled
};

class Costmap {
 public:
  Costmap() = default;
  Costmap(const OccupancyGrid& grid, const InflationOptions& options);

  const OccupancyGrid& grid() const { return grid_; }
  const InflationOptions& options() const { return options_; }
  // Distance in metres from the cell's centre to the nearest occupied cell's centre.
  float clearance(Cell c) const { return clearance_[grid_.index(c)]; }
  // Outside the grid counts as lethal.
  bool lethal(Cell c) const { return !grid_.inside(c) || lethal_[grid_.index(c)] != 0; }
  // The factor (>= 1) a step into the cell is multiplied by.
  float stepFactor(Cell c) const { return factor_[grid_.index(c)]; }
  // Marks the cells within `radius` of a point occupied (an obstacle seen by a
  // sonar or a bumper) and updates the inflation around them.
  void addObstacle(Point2 p, double radius);

 private:
  void inflateAround(Cell centre, int reachCells);
  void classify(std::size_t i);

  OccupancyGrid grid_;
  InflationOptions options_;
  std::vector<float> clearance_;
  std::vector<std::uint8_t> lethal_;
  std::vector<float> factor_;
};

// The exact Euclidean distance (in cells) from every cell to the nearest
// occupied cell; a grid with no occupied cell gives a large value everywhere.
std::vector<float> distanceTransform(const OccupancyGrid& grid);

}  // namespace peis::nav
