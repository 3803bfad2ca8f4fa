// OccupancyGrid: the map of a home at its resolution (5 cm for the
// PEIS-Home): a cell is occupied when a wall or a piece of furniture covers
// its centre or comes closer than half a cell to it (so an obstacle whose
// edge lies on a cell border takes exactly the cells it covers). Cell (0, 0) is the
// bottom-left of the map. Published by the world as a PGM image (`map`).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/world/world.h"

namespace peis::sim {

class OccupancyGrid {
 public:
  OccupancyGrid(int columns, int rows, double resolution, Vec2 origin = {});
  static OccupancyGrid fromWorld(const World& world);

  int columns() const { return columns_; }
  int rows() const { return rows_; }
  double resolution() const { return resolution_; }
  Vec2 origin() const { return origin_; }
  bool occupied(int column, int row) const;  // outside the grid counts as occupied
  void set(int column, int row, bool occupied);
  // The cell holding a point (may be outside the grid).
  std::pair<int, int> cellOf(Vec2 p) const;
  Vec2 centreOf(int column, int row) const;
  std::size_t occupiedCount() const;

  // Binary PGM (P5), 255 free, 0 occupied, row 0 of the image = the top row.
  std::string toPgm() const;
  // "RESOLUTION ORIGIN_X ORIGIN_Y WIDTH HEIGHT" (the map.info tuple).
  std::string info() const;
  // Reads toPgm()'s output back (with info's resolution and origin);
  // throws std::invalid_argument on anything else.
  static OccupancyGrid fromPgm(const std::string& pgm, double resolution, Vec2 origin);

 private:
  int columns_, rows_;
  double resolution_;
  Vec2 origin_;
  std::vector<std::uint8_t> cells_;  // 1 occupied, row-major from the bottom row
};

}  // namespace peis::sim
