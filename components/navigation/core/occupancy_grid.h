// The occupancy grid navigation plans on, as the map server publishes it
// (docs/components/sim-world.md: `map` is a binary PGM with row 0 at the top,
// `map.info` is "RESOLUTION ORIGIN_X ORIGIN_Y WIDTH HEIGHT"). Internally row 0
// is the bottom row (smallest y), so cell (cx, cy) grows with (x, y).
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "pose.h"

namespace peis::nav {

// A map that cannot be read: the message says what is wrong.
class MapError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct GridInfo {
  double resolution = 0.05;         // metres per cell
  double originX = 0, originY = 0;  // map coordinates of the lower-left corner
  int width = 0, height = 0;        // cells
  bool operator==(const GridInfo&) const = default;
};

struct Cell {
  int x = 0, y = 0;
  bool operator==(const Cell&) const = default;
};

class OccupancyGrid {
 public:
  OccupancyGrid() = default;
  // All cells free.
  explicit OccupancyGrid(GridInfo info);

  const GridInfo& info() const { return info_; }
  int width() const { return info_.width; }
  int height() const { return info_.height; }
  bool inside(Cell c) const {
    return c.x >= 0 && c.y >= 0 && c.x < info_.width && c.y < info_.height;
  }
  bool occupied(Cell c) const { return occupied_[index(c)] != 0; }
  void setOccupied(Cell c, bool occupied) { occupied_[index(c)] = occupied ? 1 : 0; }
  std::size_t index(Cell c) const {
    return static_cast<std::size_t>(c.y) * static_cast<std::size_t>(info_.width) +
           static_cast<std::size_t>(c.x);
  }
  // The cell that contains a map point (it may be outside the grid).
  Cell cellOf(Point2 p) const;
  // The centre of a cell in map coordinates.
  Point2 centreOf(Cell c) const;
  bool contains(Point2 p) const { return inside(cellOf(p)); }
  const std::vector<std::uint8_t>& cells() const { return occupied_; }

 private:
  GridInfo info_;
  std::vector<std::uint8_t> occupied_;  // 1 = occupied, row 0 = bottom
};

// Parses `map.info`. Throws MapError naming the problem.
GridInfo parseMapInfo(std::string_view text);
// Parses the `map` PGM (P5, maxval < 256) against `info` (sizes must agree).
// A cell is occupied when its grey value is below 128 (0 = occupied, 255 = free).
OccupancyGrid parsePgmMap(std::string_view pgm, const GridInfo& info);
// The inverse of parsePgmMap (for tests and benchmarks).
std::string toPgm(const OccupancyGrid& grid);

}  // namespace peis::nav
