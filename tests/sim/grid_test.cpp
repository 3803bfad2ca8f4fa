// Unit tests of the occupancy grid (sim/world/occupancy_grid.h).
#include <catch2/catch.hpp>

#include "sim/world/occupancy_grid.h"
#include "test_worlds.h"

using peis::sim::OccupancyGrid;
using peis::sim::parseWorld;

TEST_CASE("the grid covers the map at its resolution and marks walls and furniture", "[unit]") {
  const auto world = parseWorld(peis::test::boxWorld(), "box.yaml");
  const auto grid = OccupancyGrid::fromWorld(world);
  CHECK(grid.columns() == 80);
  CHECK(grid.rows() == 60);
  // The 1 m box from (2.5, 1.0) to (3.5, 2.0): its cells and no others inside the walls.
  CHECK(grid.occupied(60, 30));        // (3.025, 1.525): inside the box
  CHECK(grid.occupied(50, 20));        // (2.525, 1.025): inside near the corner
  CHECK_FALSE(grid.occupied(49, 20));  // (2.475, ...): the cell only touches the edge
  CHECK_FALSE(grid.occupied(20, 30));  // the middle of the free floor
  // Walls of 10 cm thickness centred on the border cover the first cell.
  CHECK(grid.occupied(0, 30));
  CHECK_FALSE(grid.occupied(1, 30));
  CHECK(grid.occupied(-1, 0));  // outside the grid counts as occupied
  // The box covers exactly 20 x 20 cells.
  std::size_t boxCells = 0;
  for (int r = 10; r < 50; ++r)
    for (int c = 30; c < 75; ++c) boxCells += grid.occupied(c, r);
  CHECK(boxCells == 20 * 20);
}

TEST_CASE("the PEIS-Home grid has open doors and closed walls", "[unit]") {
  const auto world = peis::sim::loadWorldFile(peis::test::peisHomePath());
  const auto grid = OccupancyGrid::fromWorld(world);
  CHECK(grid.columns() == 180);
  CHECK(grid.rows() == 120);
  const auto at = [&](double x, double y) {
    const auto [c, r] = grid.cellOf({x, y});
    return grid.occupied(c, r);
  };
  CHECK_FALSE(at(5.0, 4.0));  // the bedroom door
  CHECK_FALSE(at(5.0, 1.4));  // the kitchen door
  CHECK(at(5.0, 3.0));        // the wall between them
  CHECK(at(8.0, 4.9));        // the bed
  CHECK(at(2.6, 0.5));        // the sofa
  CHECK(at(0.3, 3.4));        // the plant (a fixed object)
  CHECK(at(4.0, 0.45));       // the lamp's base
  CHECK_FALSE(at(2.2, 3.2));  // the parcel moves: not in the map
  for (const auto& place : world.places) CHECK_FALSE(at(place.pose.x, place.pose.y));
}

TEST_CASE("the grid round-trips through PGM with row 0 at the top", "[unit]") {
  OccupancyGrid grid(3, 2, 0.5, {1, 2});
  grid.set(0, 0, true);  // bottom-left
  grid.set(2, 1, true);  // top-right
  const std::string pgm = grid.toPgm();
  REQUIRE(pgm.substr(0, 11) == "P5\n3 2\n255\n");
  const std::string pixels = pgm.substr(11);
  CHECK(pixels == std::string("\xff\xff\x00\x00\xff\xff", 6));
  const auto back = OccupancyGrid::fromPgm(pgm, 0.5, {1, 2});
  CHECK(back.occupied(0, 0));
  CHECK(back.occupied(2, 1));
  CHECK_FALSE(back.occupied(1, 0));
  CHECK(grid.info() == "0.5000 1.0000 2.0000 3 2");
  CHECK_THROWS_AS(OccupancyGrid::fromPgm("P5\n3 2\n255\nab", 0.5, {}), std::invalid_argument);
  CHECK_THROWS_AS(OccupancyGrid::fromPgm("garbage", 0.5, {}), std::invalid_argument);
}
