// The home's devices as separate processes with the simulated world: the
// photo camera against the light model (too dark, then the lamp on), the
// vacuum cleaner's refusals and its push-or-avoid decision from a weight
// tuple, and a tiny node's light sensor fed from the world.
#include <catch2/catch.hpp>
#include <fstream>
#include <random>
#include <sstream>

#include "execution/exec_protocol.h"
#include "home_support.h"
#include "support/temp_dir.h"

using peis::test::Home;
using peis::test::programPath;
using peis::test::waitFor;
using namespace std::chrono_literals;

namespace {

std::optional<peis::exec::ExecStatus> finalStatus(Home& home, peis::PeisId peis, std::uint64_t id) {
  std::optional<peis::exec::ExecStatus> status;
  waitFor(
      [&] {
        const auto t = home.observer->get(peis, "ExecStatus");
        status = t ? peis::exec::parseExecStatus(t->data) : std::nullopt;
        return status && status->goalId == id && status->state != peis::exec::ExecState::Running;
      },
      60s);
  return status;
}

}  // namespace

TEST_CASE("the photo of the sofa is too dark until the lamp is on", "[integration]") {
  Home home("photo");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  home.start(programPath("peis-photo-camera"),
             {"--peis-name", "Astrid-camera", "--min-brightness", "60", "--full-exposure", "100"});
  const peis::PeisId camera = home.await("Astrid-camera"), world = home.await("world");
  REQUIRE(camera != 0);
  REQUIRE(world != 0);
  home.observer->subscribe(peis::Pattern("ExecStatus", camera));
  home.observer->subscribe(peis::Pattern("photo.*", camera));
  home.observer->subscribe(peis::Pattern("photo", camera));
  home.observer->subscribe(peis::Pattern("physics.light.sofa", world));
  // Night outside: only the lamp can light the sofa.
  home.observer->set(world, "physics.daylight", "0");
  REQUIRE(waitFor(
      [&] {
        const auto lux = home.observer->get(world, "physics.light.sofa");
        return lux && std::stod(lux->data) < 30;
      },
      30s));
  auto goal = home.observer->set(camera, "ExecGoal", "Photo(sofa)");
  auto status = finalStatus(home, camera, goal.seqno);
  REQUIRE(status);
  CHECK(status->state == peis::exec::ExecState::Failed);
  CHECK(status->cause.rfind("too dark (brightness ", 0) == 0);
  const auto darkBrightness = home.observer->get(camera, "photo.brightness");
  REQUIRE(darkBrightness);
  const double dark = std::stod(darkBrightness->data);
  const auto photo = home.observer->get(camera, "photo");
  REQUIRE(photo);
  CHECK(photo->mimetype == "image/png");
  CHECK(photo->data.substr(1, 3) == "PNG");

  home.observer->set(world, "physics.lamp.lamp.level", "100");
  REQUIRE(waitFor(
      [&] {
        const auto lux = home.observer->get(world, "physics.light.sofa");
        return lux && std::stod(lux->data) > 100;
      },
      30s));
  goal = home.observer->set(camera, "ExecGoal", "Photo(sofa)");
  status = finalStatus(home, camera, goal.seqno);
  REQUIRE(status);
  CHECK(status->toString() == "success " + std::to_string(goal.seqno) + " Photo(sofa)");
  const auto litBrightness = home.observer->get(camera, "photo.brightness");
  REQUIRE(litBrightness);
  CHECK(std::stod(litBrightness->data) > dark + 30);
  CHECK_THROWS_AS(home.observer->set(camera, "ExecGoal", "Photo()"), peis::Error);
  goal = home.observer->set(camera, "ExecGoal", "Photo(attic)");
  status = finalStatus(home, camera, goal.seqno);
  REQUIRE(status);
  CHECK(status->cause == "no light reading at 'attic'");
}

TEST_CASE("the vacuum needs a position to clean and decides push or avoid from a weight",
          "[integration]") {
  Home home("vacuum");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  home.start(programPath("peis-vacuum"), {"--peis-name", "vacuum", "--base", "vacuum-base"});
  const peis::PeisId vacuum = home.await("vacuum");
  REQUIRE(vacuum != 0);
  home.observer->subscribe(peis::Pattern("ExecStatus", vacuum));
  home.observer->subscribe(peis::Pattern("obstacle.decision", vacuum));
  // No mi-position: it refuses to start.
  auto goal = home.observer->set(vacuum, "ExecGoal", "Clean(living-room)");
  auto status = finalStatus(home, vacuum, goal.seqno);
  REQUIRE(status);
  CHECK(status->cause == "no position: mi-position is not configured or stale");
  CHECK_THROWS_AS(home.observer->set(vacuum, "ExecGoal", "GoTo(bed)"), peis::Error);
  // A weight from the ecology (here the referee stands in for the parcel's node).
  home.observer->set("Weight", "800");
  REQUIRE(home.cli({"meta", "vacuum.mi-weight", "referee.Weight"}) == 0);
  CHECK(waitFor(
      [&] {
        const auto d = home.observer->get(vacuum, "obstacle.decision");
        return d && d->data == "push: 800 g <= 1000 g";
      },
      30s));
  home.observer->set("Weight", "2500");
  CHECK(waitFor(
      [&] {
        const auto d = home.observer->get(vacuum, "obstacle.decision");
        return d && d->data == "avoid: 2500 g > 1000 g";
      },
      30s));
}

TEST_CASE("the vacuum waits a while for the first position of a configured input",
          "[integration]") {
  Home home("vacuum-wait");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  auto& vac = home.start(programPath("peis-vacuum"), {"--peis-name", "vacuum", "--base",
                                                      "vacuum-base", "--position-wait", "3"});
  const peis::PeisId vacuum = home.await("vacuum");
  REQUIRE(vacuum != 0);
  REQUIRE(home.await("world") != 0);
  home.observer->subscribe(peis::Pattern("ExecStatus", vacuum));
  // Configured, but nothing delivered: Clean runs, waiting, then fails.
  REQUIRE(home.cli({"meta", "vacuum.mi-position", "referee.position"}) == 0);
  auto goal = home.observer->set(vacuum, "ExecGoal", "Clean(living-room)");
  auto status = finalStatus(home, vacuum, goal.seqno);
  REQUIRE(status);
  CHECK(status->cause == "no position: mi-position delivered none in time (--position-wait)");
  // A position that arrives within the wait starts the cleaning.
  goal = home.observer->set(vacuum, "ExecGoal", "Clean(living-room)");
  peis::WriteOptions at;
  at.ts_user = peis::systemNow();
  home.observer->set("position", "1.0 1.6", at);
  CHECK(waitFor([&] { return vac.err().find("vacuum: cleaning living-room") != std::string::npos; },
                30s));
  const auto running = home.observer->get(vacuum, "ExecStatus");
  REQUIRE(running);
  CHECK(running->data.rfind("running " + std::to_string(goal.seqno), 0) == 0);
}

TEST_CASE("a tiny plant reads the world's light through its sensor file", "[integration]") {
  Home home("sensors");
  peis::test::TempDir dir("sensors");
  const std::string file = dir.file("plant.sensors");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  home.start(programPath("peis-sim-sensors"), {"--light", "plant=" + file, "--lux-per-level", "2"});
  const peis::PeisId world = home.await("world");
  REQUIRE(world != 0);
  home.observer->subscribe(peis::Pattern("physics.light.plant", world));
  // A bright day: the sun on the plant is over the plant's threshold.
  home.observer->set(world, "physics.daylight", "40000");
  std::string text;
  REQUIRE(waitFor(
      [&] {
        std::ifstream in(file);
        std::stringstream s;
        s << in.rdbuf();
        text = s.str();
        return text.rfind("light ", 0) == 0 && std::stol(text.substr(6)) > 700;
      },
      30s));
  const long level = std::stol(text.substr(6));
  const double lux = std::stod(home.observer->get(world, "physics.light.plant")->data);
  CHECK(std::abs(level - std::lround(std::min(1000.0, lux / 2))) <= std::max(5.0, 0.05 * level));
  // The plant on the host port reads that level through its HAL.
  std::random_device random;
  const std::string medium = std::to_string(40000 + random() % 20000);
  peis::test::Process plant({PEIS_TINY_PLANT_PATH},
                            {{"TINY_SENSOR_FILE", file}, {"TINY_MEDIUM_PORT", medium}});
  REQUIRE(waitFor([&] { return plant.out().find("plant light ") != std::string::npos; }, 30s));
  const std::string out = plant.out();
  const long seen = std::stol(out.substr(out.find("plant light ") + 12));
  CHECK(std::abs(seen - level) <= std::max(5L, level / 20));
  CHECK(out.find("plant tilt 0") != std::string::npos);  // asks the blind to close
}

TEST_CASE("a frozen sensor keeps its last reading until it thaws", "[fault]") {
  Home home("freeze");
  peis::test::TempDir dir("freeze");
  const std::string file = dir.file("plant.sensors");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  auto& sensorsProcess =
      home.start(programPath("peis-sim-sensors"),
                 {"--peis-name", "sensors", "--light", "plant=" + file, "--lux-per-level", "2"});
  const peis::PeisId world = home.await("world"), sensors = home.await("sensors");
  REQUIRE(world != 0);
  REQUIRE(sensors != 0);
  auto level = [&]() -> long {
    std::ifstream in(file);
    std::string word;
    long value = -1;
    in >> word >> value;
    return word == "light" ? value : -1;
  };
  home.observer->set(world, "physics.daylight", "40000");
  const bool bright = waitFor([&] { return level() > 700; }, 30s);
  INFO(home.describeAll());
  REQUIRE(bright);
  home.observer->set(sensors, "fault.freeze", "on");
  // The set is acknowledged when stored; a reading already on its way may
  // still be written until the sensor has taken the fault.
  REQUIRE(waitFor([&] { return sensorsProcess.err().find("readings frozen") != std::string::npos; },
                  30s));
  const long stuck = level();
  // Night falls; the frozen sensor still reads the sun.
  home.observer->subscribe(peis::Pattern("physics.light.plant", world));
  home.observer->set(world, "physics.daylight", "0");
  REQUIRE(waitFor(
      [&] {
        const auto lux = home.observer->get(world, "physics.light.plant");
        return lux && std::stod(lux->data) < 50;
      },
      30s));
  CHECK_FALSE(waitFor([&] { return level() != stuck; }, 3s));
  home.observer->set(sensors, "fault.freeze", "off");
  CHECK(waitFor([&] { return level() >= 0 && level() < 50; }, 30s));
}

TEST_CASE("every home component's --help shows its own options and the PEIS flags",
          "[integration]") {
  Home home("help");
  for (const char* program : {"peis-navigation", "peis-executor", "peis-sim-sensors",
                              "peis-photo-camera", "peis-vacuum", "peis-talk"}) {
    auto& help = home.start(programPath(program), {"--help"});
    INFO(program << "\n" << help.describe());
    REQUIRE(help.wait(30s) == 0);
    // The program's usage says [OPTIONS]; the Kernel's own, [options].
    CHECK(help.out().rfind(std::string("Usage: ") + program + " [OPTIONS]", 0) == 0);
    CHECK(help.out().find("--peis-name") != std::string::npos);
  }
}
