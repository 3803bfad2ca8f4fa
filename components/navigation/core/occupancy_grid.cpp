// Reading the map server's grid: map.info and the binary PGM, every length
// and number checked.
#include "occupancy_grid.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <sstream>

namespace peis::nav {

OccupancyGrid::OccupancyGrid(GridInfo info)
    : info_(info),
      occupied_(static_cast<std::size_t>(info.width) * static_cast<std::size_t>(info.height), 0) {}

Cell OccupancyGrid::cellOf(Point2 p) const {
  return {static_cast<int>(std::floor((p.x - info_.originX) / info_.resolution)),
          static_cast<int>(std::floor((p.y - info_.originY) / info_.resolution))};
}

Point2 OccupancyGrid::centreOf(Cell c) const {
  return {info_.originX + (c.x + 0.5) * info_.resolution,
          info_.originY + (c.y + 0.5) * info_.resolution};
}

namespace {

constexpr int kMaxCellsPerSide = 20000;

double parseNumber(const std::string& token, const char* what) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(token, &used);
  } catch (const std::exception&) {
    throw MapError(std::string("map.info: ") + what + " '" + token + "' is not a number");
  }
  if (used != token.size() || !std::isfinite(value))
    throw MapError(std::string("map.info: ") + what + " '" + token + "' is not a number");
  return value;
}

// Reads one whitespace-separated header token of a PGM, skipping # comments.
std::string pgmToken(std::string_view pgm, std::size_t& pos) {
  while (pos < pgm.size()) {
    if (std::isspace(static_cast<unsigned char>(pgm[pos]))) {
      ++pos;
    } else if (pgm[pos] == '#') {
      while (pos < pgm.size() && pgm[pos] != '\n') ++pos;
    } else {
      break;
    }
  }
  const std::size_t start = pos;
  while (pos < pgm.size() && !std::isspace(static_cast<unsigned char>(pgm[pos]))) ++pos;
  return std::string(pgm.substr(start, pos - start));
}

int pgmInt(std::string_view pgm, std::size_t& pos, const char* what) {
  const std::string token = pgmToken(pgm, pos);
  int value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (token.empty() || ec != std::errc() || end != token.data() + token.size() || value <= 0)
    throw MapError(std::string("map: the PGM header's ") + what + " '" + token +
                   "' is not a positive number");
  return value;
}

}  // namespace

GridInfo parseMapInfo(std::string_view text) {
  std::istringstream in{std::string(text)};
  std::vector<std::string> tokens;
  for (std::string token; in >> token;) tokens.push_back(token);
  if (tokens.size() != 5)
    throw MapError("map.info: expected 'RESOLUTION ORIGIN_X ORIGIN_Y WIDTH HEIGHT', got " +
                   std::to_string(tokens.size()) + " fields");
  GridInfo info;
  info.resolution = parseNumber(tokens[0], "RESOLUTION");
  info.originX = parseNumber(tokens[1], "ORIGIN_X");
  info.originY = parseNumber(tokens[2], "ORIGIN_Y");
  const double width = parseNumber(tokens[3], "WIDTH");
  const double height = parseNumber(tokens[4], "HEIGHT");
  if (info.resolution <= 0) throw MapError("map.info: RESOLUTION must be positive");
  for (double side : {width, height})
    if (side < 1 || side > kMaxCellsPerSide || side != std::floor(side))
      throw MapError("map.info: WIDTH and HEIGHT must be whole numbers in 1.." +
                     std::to_string(kMaxCellsPerSide));
  info.width = static_cast<int>(width);
  info.height = static_cast<int>(height);
  return info;
}

OccupancyGrid parsePgmMap(std::string_view pgm, const GridInfo& info) {
  std::size_t pos = 0;
  if (pgmToken(pgm, pos) != "P5") throw MapError("map: not a binary PGM (P5)");
  const int width = pgmInt(pgm, pos, "width");
  const int height = pgmInt(pgm, pos, "height");
  const int maxval = pgmInt(pgm, pos, "maxval");
  if (maxval > 255) throw MapError("map: 16-bit PGM is not supported");
  if (width != info.width || height != info.height)
    throw MapError("map: the PGM is " + std::to_string(width) + "x" + std::to_string(height) +
                   " cells but map.info says " + std::to_string(info.width) + "x" +
                   std::to_string(info.height));
  if (pos >= pgm.size()) throw MapError("map: the PGM has no pixel data");
  ++pos;  // the single whitespace after maxval
  const std::size_t need = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (pgm.size() - pos != need)
    throw MapError("map: the PGM has " + std::to_string(pgm.size() - pos) + " bytes of pixels, " +
                   std::to_string(need) + " expected");
  OccupancyGrid grid(info);
  const int threshold = (maxval + 1) / 2;
  for (int row = 0; row < height; ++row) {
    const int cy = height - 1 - row;  // PGM row 0 is the top
    for (int cx = 0; cx < width; ++cx) {
      const auto grey =
          static_cast<unsigned char>(pgm[pos + static_cast<std::size_t>(row) * width + cx]);
      if (grey < threshold) grid.setOccupied({cx, cy}, true);
    }
  }
  return grid;
}

std::string toPgm(const OccupancyGrid& grid) {
  std::string out =
      "P5\n" + std::to_string(grid.width()) + " " + std::to_string(grid.height()) + "\n255\n";
  out.reserve(out.size() + grid.cells().size());
  for (int row = 0; row < grid.height(); ++row) {
    const int cy = grid.height() - 1 - row;
    for (int cx = 0; cx < grid.width(); ++cx)
      out.push_back(grid.occupied({cx, cy}) ? '\0' : static_cast<char>(255));
  }
  return out;
}

}  // namespace peis::nav
