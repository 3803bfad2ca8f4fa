// Unit tests of the simulation step (sim/world/simulation.h): robots stop
// at walls with their bumper pressed, odometry without noise is the truth,
// a command times out, sonars measure distances, light parcels are pushed
// and heavy ones block, talk wakes people within hearing.
#include "sim/world/simulation.h"

#include <catch2/catch.hpp>
#include <cmath>

#include "sim/world/scene.h"
#include "test_worlds.h"

using namespace peis::sim;

namespace {

World boxWorldWith(const std::string& robots, const std::string& extra = "") {
  return parseWorld(peis::test::boxWorld(robots, extra), "box.yaml");
}

const std::string kExactRobot =
    "  - {name: r1, pose: [1, 1.5, 0], radius: 0.2, max_speed: 0.5, push_kg: 3,\n"
    "     odometry_noise: {trans: 0, rot: 0, drift: 0}, sonar: {angles_deg: [0, 180, 90]}}\n";

// Drives for `seconds`, repeating the command every 0.5 s as a controller would.
void drive(Simulation& sim, Velocity v, double seconds) {
  for (double t = 0; t < seconds; t += 0.01) {
    if (std::fmod(t, 0.5) < 0.01) sim.command(0, v);
    sim.step(0.01);
  }
}

}  // namespace

TEST_CASE("a robot driving into furniture stops at it with its bumper pressed", "[unit]") {
  Simulation sim(boxWorldWith(kExactRobot), 1);
  drive(sim, {0.5, 0}, 6);
  const auto& r = sim.robot(0);
  // The box's left face is at x = 2.5; the robot's radius is 0.2.
  CHECK(r.pose.x <= 2.3);
  CHECK(r.pose.x >= 2.28);
  CHECK(r.pose.y == Approx(1.5));
  CHECK(r.bumper);
  CHECK(r.velocity.v == 0);
  // It can still turn in place, and drive away, which releases the bumper.
  drive(sim, {0, 1.0}, M_PI);
  drive(sim, {0.3, 0}, 1);
  CHECK_FALSE(sim.robot(0).bumper);
  CHECK(sim.robot(0).pose.x < 2.2);
}

TEST_CASE("odometry without noise is the ground truth and with noise it drifts", "[unit]") {
  Simulation exact(boxWorldWith(kExactRobot), 1);
  drive(exact, {0.3, 0.4}, 5);
  CHECK(exact.robot(0).odometry.x == Approx(exact.robot(0).pose.x).margin(1e-9));
  CHECK(exact.robot(0).odometry.y == Approx(exact.robot(0).pose.y).margin(1e-9));
  CHECK(exact.robot(0).odometry.theta == Approx(exact.robot(0).pose.theta).margin(1e-9));

  Simulation drifting(
      boxWorldWith(
          "  - {name: r1, pose: [1, 1.5, 0], odometry_noise: {trans: 0.1, rot: 0.1, drift: 10}}\n"),
      3);
  drive(drifting, {0.3, 0.4}, 5);
  const auto& r = drifting.robot(0);
  const double error = std::hypot(r.odometry.x - r.pose.x, r.odometry.y - r.pose.y);
  CHECK(error > 0.001);
  CHECK(error < 0.5);
}

TEST_CASE("a command holds for cmd_timeout, then the robot stops", "[unit]") {
  Simulation sim(
      boxWorldWith(
          "  - {name: r1, pose: [0.5, 1.5, 0], max_speed: 0.5, max_accel: 100, cmd_timeout: 1}\n"),
      1);
  sim.command(0, {0.5, 0});
  for (int i = 0; i < 300; ++i) sim.step(0.01);
  CHECK(sim.robot(0).velocity.v == 0);
  CHECK(sim.robot(0).pose.x == Approx(0.5 + 0.5 * 1.0).margin(0.02));
  CHECK(sim.time() == Approx(3.0));
}

TEST_CASE("sonars measure the distance from the robot's rim to what is there", "[unit]") {
  Simulation sim(boxWorldWith(kExactRobot), 1);
  const auto ranges = sim.sonar(0);
  REQUIRE(ranges.size() == 3);
  // Ahead: the box at x = 2.5 from x = 1 minus the radius; behind: the wall's face at 0.05.
  CHECK(ranges[0] == Approx(1.5 - 0.2).margin(0.1));
  CHECK(ranges[1] == Approx(0.95 - 0.2).margin(0.1));
  // Left: the wall at y = 3 - 0.05 is 1.45 away; the sonar reaches 3 m.
  CHECK(ranges[2] == Approx(1.45 - 0.2).margin(0.1));
  CHECK(sim.castRay({1, 1.5}, M_PI / 2, 1.0, 0) == 1.0);  // limited by the range
}

TEST_CASE("a robot pushes a parcel it may push and is blocked by a heavier one", "[unit]") {
  const auto parcel = [](double kg) {
    return "objects:\n  - {name: parcel, position: [1.6, 1.5], size: [0.3, 0.3], weight_kg: " +
           std::to_string(kg) + ", movable: true}\n";
  };
  Simulation light(boxWorldWith(kExactRobot, parcel(1.0)), 1);
  drive(light, {0.3, 0}, 2);
  CHECK(light.objectPose(0).x > 1.75);
  CHECK_FALSE(light.robot(0).bumper);
  CHECK(light.robot(0).pose.x > 1.2);

  Simulation heavy(boxWorldWith(kExactRobot, parcel(5.0)), 1);
  drive(heavy, {0.3, 0}, 2);
  CHECK(heavy.objectPose(0).x == Approx(1.6));
  CHECK(heavy.robot(0).bumper);
  // Stopped at the parcel's collision disk (radius 0.212) plus its own.
  CHECK(heavy.robot(0).pose.x <= 1.6 - 0.2 - 0.212 + 1e-9);
}

TEST_CASE("a robot can never leave the map, even where no wall is", "[unit]") {
  auto world = parseWorld(
      "name: open\nsize: [2, 2]\nrobots:\n  - {name: r1, pose: [1, 1, 0], radius: 0.2}\n",
      "open.yaml");
  Simulation sim(std::move(world), 1);
  drive(sim, {0.5, 0}, 5);
  CHECK(sim.robot(0).pose.x <= 1.8 + 1e-9);
  CHECK(sim.robot(0).bumper);
}

TEST_CASE("the battery drains with time and faster when driving", "[unit]") {
  Simulation idle(boxWorldWith("  - {name: r1, pose: [1, 1.5, 0], battery_hours: 0.01}\n"), 1);
  for (int i = 0; i < 100; ++i) idle.step(0.1);
  const double idleLeft = idle.robot(0).battery;
  CHECK(idleLeft < 100);
  Simulation moving(boxWorldWith("  - {name: r1, pose: [1, 1.5, 0], battery_hours: 0.01}\n"), 1);
  drive(moving, {0, 1.0}, 10);
  CHECK(moving.robot(0).battery < idleLeft);
}

TEST_CASE("talk wakes the people within hearing", "[unit]") {
  const std::string people =
      "people:\n  - {name: near, position: [1.5, 1.5], state: asleep, hearing_m: 1}\n"
      "  - {name: far, position: [3.8, 2.8], state: asleep, hearing_m: 1}\n";
  Simulation sim(boxWorldWith(kExactRobot, people), 1);
  const Speech speech = sim.talk(0, "wakeup");
  CHECK(speech.text == "wakeup");
  CHECK(speech.robot == "r1");
  REQUIRE(speech.woke == std::vector<std::string>{"near"});
  CHECK(sim.personState(0) == "awake");
  CHECK(sim.personState(1) == "asleep");
  CHECK(sim.talk(0, "again").woke.empty());
}

TEST_CASE("the physics scene round-trips through its text", "[unit]") {
  Simulation sim(parseWorld(peis::test::boxWorld(
                                kExactRobot,
                                "people:\n  - {name: p, position: [3, 2.8], state: asleep}\n"
                                "lamps:\n  - {name: lamp, position: [0.5, 0.5], level: 30}\n"),
                            "box.yaml"),
                 1);
  drive(sim, {0.2, 0.1}, 1);
  const Scene scene = sceneOf(sim);
  const Scene back = parseScene(formatScene(scene));
  CHECK(back.time == Approx(scene.time).margin(1e-4));
  REQUIRE(back.robots.size() == 1);
  CHECK(back.robots[0].name == "r1");
  CHECK(back.robots[0].pose.x == Approx(sim.robot(0).pose.x).margin(1e-4));
  CHECK(back.robots[0].pose.theta == Approx(sim.robot(0).pose.theta).margin(1e-5));
  CHECK(back.lamps == std::vector<std::pair<std::string, double>>{{"lamp", 30.0}});
  CHECK(back.people == std::vector<std::pair<std::string, std::string>>{{"p", "asleep"}});
  // Unknown kinds are skipped; broken known lines are errors naming the line.
  CHECK(parseScene("time 1\nweather sunny\n").time == 1);
  CHECK_THROWS_WITH(parseScene("time 1\nrobot r1 1 2\n"),
                    Catch::Matchers::Contains("scene line 2 is malformed"));
  CHECK_THROWS_AS(parseScene("robot r1 nan 1 2\n"), std::invalid_argument);
}
