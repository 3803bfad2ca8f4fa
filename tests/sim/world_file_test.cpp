// Unit tests of world files (sim/world/world.h): the PEIS-Home loads, and
// broken files give errors that name file:line and the problem.
#include <catch2/catch.hpp>

#include "peis/error.h"
#include "sim/world/world.h"
#include "support/temp_dir.h"
#include "test_worlds.h"

using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using peis::sim::parseWorld;

namespace {

std::string errorOf(const std::string& text) {
  try {
    parseWorld(text, "home.yaml");
  } catch (const peis::Error& e) {
    CHECK(e.code() == peis::ErrorCode::InvalidConfig);
    return e.what();
  }
  return "no error";
}

const std::string kRobot = "  - {name: r1, pose: [1, 1, 90], radius: 0.2}\n";

}  // namespace

TEST_CASE("the PEIS-Home world file loads with its rooms, robots, cameras and places", "[unit]") {
  const auto world = peis::sim::loadWorldFile(peis::test::peisHomePath());
  CHECK(world.name == "peis-home");
  CHECK(world.rooms.size() == 3);
  REQUIRE(world.robot("Pippi") != nullptr);
  CHECK(world.robot("Pippi")->driver == "Pippi-base");
  CHECK(world.robot("Astrid") != nullptr);
  CHECK(world.robot("Emil") != nullptr);
  CHECK(world.robot("vacuum") != nullptr);
  CHECK(world.cameras.size() == 3);
  REQUIRE(world.place("bed") != nullptr);
  CHECK(world.place("sofa") != nullptr);
  CHECK(world.people.size() == 1);
  CHECK(world.people[0].state == "asleep");
  CHECK(world.windows[0].blind == "blind");
  CHECK(world.robot("Pippi")->start.theta == Approx(M_PI).margin(1e-9));
  CHECK(world.sourceText.find("peis-home") != std::string::npos);
}

TEST_CASE("a small world parses with defaults", "[unit]") {
  const auto world = parseWorld(peis::test::boxWorld(kRobot), "box.yaml");
  REQUIRE(world.robots.size() == 1);
  CHECK(world.robots[0].start.x == 1);
  CHECK(world.robots[0].sonarAngles.size() == 8);
  CHECK(world.robots[0].driver == "r1-base");
  CHECK(world.furniture[0].polygon.size() == 4);
}

TEST_CASE("broken world files name the file, the line and the problem", "[unit]") {
  using peis::test::boxWorld;
  CHECK_THAT(errorOf("name: [unclosed\n"), StartsWith("home.yaml:2: not valid YAML"));
  CHECK_THAT(errorOf("- a\n- b\n"), StartsWith("home.yaml:1: a world file must be a mapping"));
  CHECK_THAT(errorOf(boxWorld("", "colour_of_sky: blue\n")),
             StartsWith("home.yaml:12: unknown key 'colour_of_sky' in the world file"));
  CHECK_THAT(errorOf("size: [1, 1]\n"), Contains("the world file needs 'name'"));
  // The first robot is line 13 of boxWorld.
  CHECK_THAT(errorOf(boxWorld("  - {name: r1, pose: [7, 1, 0]}\n")),
             StartsWith("home.yaml:13: robot r1 pose (7, 1) is outside the map [0, 4] x [0, 3]"));
  CHECK_THAT(errorOf(boxWorld("  - {name: r1, pose: [3, 1.5, 0]}\n")),
             StartsWith("home.yaml:13: robot 'r1' starts inside furniture 'box'"));
  CHECK_THAT(errorOf(boxWorld("  - {name: r1, pose: [0.1, 1.5, 0]}\n")),
             StartsWith("home.yaml:13: robot 'r1' starts inside a wall"));
  CHECK_THAT(errorOf(boxWorld(kRobot + kRobot)),
             StartsWith("home.yaml:14: robot 'r1' is declared twice"));
  CHECK_THAT(errorOf(boxWorld("  - {name: r.1, pose: [1, 1, 0]}\n")),
             Contains("robot name 'r.1' must be one key part"));
  CHECK_THAT(
      errorOf(boxWorld("  - {name: r1, pose: [1, 1]}\n")),
      StartsWith("home.yaml:13: robot r1 pose [x, y, theta_deg] must be a list of 3 numbers"));
  CHECK_THAT(errorOf(boxWorld("  - {name: r1, pose: [1, 1, 0], radius: big}\n")),
             Contains("robot radius must be a number, not 'big'"));
  CHECK_THAT(errorOf(boxWorld("  - {name: r1, pose: [1, 1, 0], hat: {colour: [300, 0, 0]}}\n")),
             Contains("colour values must be 0..255"));
  CHECK_THAT(errorOf(boxWorld("", "places: {door: [3, 1.5, 0]}\n")),
             StartsWith("home.yaml:12: place 'door' is inside furniture 'box'"));
  CHECK_THAT(errorOf(boxWorld("",
                              "cameras:\n  - {name: up, position: [2, 1.5, 2.5], look_at: [2, 1.5, "
                              "5], up: [0, 1, 0], fx: 300}\n")),
             Contains("camera 'up' does not look at the floor"));
  CHECK_THAT(errorOf(boxWorld("", "cameras:\n  - {name: c, position: [2, 1.5, 2.5], fx: 300}\n")),
             StartsWith("home.yaml:13: a camera needs look_at or rotation"));
  CHECK_THAT(errorOf(boxWorld("", "rooms2: []\n")), Contains("unknown key 'rooms2'"));
  CHECK_THAT(errorOf(boxWorld("", "lamps:\n  - {name: box, position: [1, 1]}\n")),
             Contains("the name 'box' is used twice"));
}

TEST_CASE("a world file that cannot be read is a clear error", "[unit]") {
  peis::test::TempDir dir("world");
  CHECK_THROWS_WITH(peis::sim::loadWorldFile(dir.file("missing.yaml")),
                    Contains("missing.yaml: cannot open the world file"));
  const auto path =
      dir.write("broken.yaml", peis::test::boxWorld("  - {name: r1, pose: [9, 9, 0]}\n"));
  CHECK_THROWS_WITH(peis::sim::loadWorldFile(path), StartsWith(path + ":13: robot r1 pose"));
}
