// The occupancy grid of a home (occupancy_grid.h).
#include "sim/world/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace peis::sim {

OccupancyGrid::OccupancyGrid(int columns, int rows, double resolution, Vec2 origin)
    : columns_(columns), rows_(rows), resolution_(resolution), origin_(origin) {
  if (columns <= 0 || rows <= 0 || resolution <= 0)
    throw std::invalid_argument("an occupancy grid needs positive sizes");
  cells_.assign(static_cast<std::size_t>(columns) * rows, 0);
}

OccupancyGrid OccupancyGrid::fromWorld(const World& world) {
  const int columns = std::max(1, static_cast<int>(std::lround(world.size.x / world.resolution)));
  const int rows = std::max(1, static_cast<int>(std::lround(world.size.y / world.resolution)));
  OccupancyGrid grid(columns, rows, world.resolution);
  // Within half a cell (a cell whose edge only touches an obstacle stays free).
  const double margin = world.resolution / 2 * (1 - 1e-6);
  for (const Polygon& obstacle : world.obstacles()) {
    // Only the cells under the obstacle's bounding box (plus a margin) can be hit.
    double minX = INFINITY, minY = INFINITY, maxX = -INFINITY, maxY = -INFINITY;
    for (const Vec2 p : obstacle) {
      minX = std::min(minX, p.x), minY = std::min(minY, p.y);
      maxX = std::max(maxX, p.x), maxY = std::max(maxY, p.y);
    }
    const auto [c0, r0] = grid.cellOf({minX - margin, minY - margin});
    const auto [c1, r1] = grid.cellOf({maxX + margin, maxY + margin});
    for (int r = std::max(0, r0); r <= std::min(rows - 1, r1); ++r)
      for (int c = std::max(0, c0); c <= std::min(columns - 1, c1); ++c) {
        const Vec2 centre = grid.centreOf(c, r);
        if (insidePolygon(obstacle, centre) || distanceToBoundary(obstacle, centre) < margin)
          grid.set(c, r, true);
      }
  }
  return grid;
}

bool OccupancyGrid::occupied(int column, int row) const {
  if (column < 0 || row < 0 || column >= columns_ || row >= rows_) return true;
  return cells_[static_cast<std::size_t>(row) * columns_ + column] != 0;
}

void OccupancyGrid::set(int column, int row, bool occupied) {
  if (column < 0 || row < 0 || column >= columns_ || row >= rows_) return;
  cells_[static_cast<std::size_t>(row) * columns_ + column] = occupied ? 1 : 0;
}

std::pair<int, int> OccupancyGrid::cellOf(Vec2 p) const {
  return {static_cast<int>(std::floor((p.x - origin_.x) / resolution_)),
          static_cast<int>(std::floor((p.y - origin_.y) / resolution_))};
}

Vec2 OccupancyGrid::centreOf(int column, int row) const {
  return {origin_.x + (column + 0.5) * resolution_, origin_.y + (row + 0.5) * resolution_};
}

std::size_t OccupancyGrid::occupiedCount() const {
  return static_cast<std::size_t>(std::count(cells_.begin(), cells_.end(), 1));
}

std::string OccupancyGrid::toPgm() const {
  std::string pgm = "P5\n" + std::to_string(columns_) + " " + std::to_string(rows_) + "\n255\n";
  const std::size_t header = pgm.size();
  pgm.resize(header + cells_.size());
  for (int r = 0; r < rows_; ++r)
    for (int c = 0; c < columns_; ++c)
      pgm[header + static_cast<std::size_t>(rows_ - 1 - r) * columns_ + c] =
          static_cast<char>(occupied(c, r) ? 0 : 255);
  return pgm;
}

std::string OccupancyGrid::info() const {
  char buffer[128];
  std::snprintf(buffer, sizeof buffer, "%.4f %.4f %.4f %d %d", resolution_, origin_.x, origin_.y,
                columns_, rows_);
  return buffer;
}

OccupancyGrid OccupancyGrid::fromPgm(const std::string& pgm, double resolution, Vec2 origin) {
  std::istringstream in(pgm);
  std::string magic;
  int columns = 0, rows = 0, maxValue = 0;
  in >> magic >> columns >> rows >> maxValue;
  if (!in || magic != "P5" || columns <= 0 || rows <= 0 || maxValue != 255 ||
      static_cast<long long>(columns) * rows > 64'000'000)
    throw std::invalid_argument("not a binary 8-bit PGM");
  in.get();  // the one whitespace byte after the header
  const std::size_t header = static_cast<std::size_t>(in.tellg());
  if (pgm.size() - header != static_cast<std::size_t>(columns) * rows)
    throw std::invalid_argument("PGM data has the wrong length");
  OccupancyGrid grid(columns, rows, resolution, origin);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      grid.set(c, r,
               static_cast<unsigned char>(
                   pgm[header + static_cast<std::size_t>(rows - 1 - r) * columns + c]) < 128);
  return grid;
}

}  // namespace peis::sim
