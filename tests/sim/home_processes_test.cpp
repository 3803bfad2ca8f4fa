// The simulated home as separate processes over the real network stack:
// peis-sim-world driven through its driver PEIS like hardware, two
// peis-camera processes and peis-tracker, whose position of a robot is
// compared with the world's ground truth; and the bad inputs of each
// program (broken files, refused writes, a camera with no image, tuples
// that are not images).
#include <signal.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include "peis/error.h"
#include "peis/kernel.h"
#include "sim/world/scene.h"
#include "support/process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"
#include "test_worlds.h"

using namespace std::chrono_literals;
using peis::test::Process;
using peis::test::waitFor;

namespace {

std::string program(const std::string& relative) {
  return std::string(PEIS_BUILD_DIR) + "/" + relative;
}

struct Home {
  std::string ecology = peis::test::uniqueEcology("home");
  peis::test::TempDir dir{"peis_home_test"};
  std::vector<std::unique_ptr<Process>> processes;
  std::unique_ptr<peis::Kernel> referee;

  Process& start(std::vector<std::string> argv) {
    argv.push_back("--peis-ecology");
    argv.push_back(ecology);
    processes.push_back(
        std::make_unique<Process>(argv, Process::Environment{{"PEIS_LOG", "warn"}}));
    return *processes.back();
  }
  Process& world(std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{program("components/sim/peis-sim-world"), "--picture",
                                  dir.file("home.png")};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return start(argv);
  }
  Process& camera(const std::string& name) {
    return start({program("components/camera/peis-camera"), "--camera", name, "--rate", "5"});
  }
  Process& tracker(int cameras = 2) {
    return start({program("components/tracking/peis-tracker"), "--targets",
                  peis::test::peisHomePath(), "--cameras", std::to_string(cameras)});
  }
  peis::Kernel& kernel() {
    if (!referee) {
      peis::Options o;
      o.ecology = ecology;
      o.name = "referee";
      referee = std::make_unique<peis::Kernel>(o);
    }
    return *referee;
  }
  // The id of the PEIS named `name`, once it is reachable.
  peis::PeisId idOf(const std::string& name) {
    peis::PeisId id = 0;
    const bool found = waitFor(
        [&] {
          try {
            id = kernel().resolveOwner(name);
            return true;
          } catch (const peis::Error&) {
            return false;
          }
        },
        30s);
    INFO(describe());
    REQUIRE(found);
    return id;
  }
  std::string describe() {
    std::string all;
    for (auto& p : processes) all += p->describe() + "\n";
    return all;
  }
  std::optional<peis::Tuple> value(peis::PeisId owner, const std::string& key) {
    return kernel().get(owner, key);
  }
  ~Home() {
    referee.reset();
    for (auto& p : processes) p->kill(SIGTERM);
    for (auto& p : processes) p->wait(10s);
  }
};

// "X Y ..." -> the first n numbers.
std::vector<double> numbers(const std::string& text, std::size_t n) {
  std::istringstream in(text);
  std::vector<double> out;
  double v = 0;
  while (out.size() < n && in >> v) out.push_back(v);
  return out;
}

}  // namespace

TEST_CASE(
    "a robot driver PEIS moves its robot from VelCommand and reports odometry, sonar, battery, "
    "bumper",
    "[integration]") {
  Home home;
  home.world({"--speed", "2"});
  auto& k = home.kernel();
  const auto base = home.idOf("Pippi-base");
  const auto world = home.idOf("world");
  k.subscribe(peis::Pattern("**", base));
  k.subscribe(peis::Pattern("physics.scene", world));
  REQUIRE(waitFor([&] { return home.value(base, "Odometry").has_value(); }, 30s));
  const auto start = numbers(home.value(base, "Odometry")->data, 3);
  REQUIRE(start.size() == 3);
  CHECK(start[0] == Approx(3.5).margin(0.01));  // the world file's start pose
  CHECK(std::abs(start[2]) == Approx(M_PI).margin(0.01));
  CHECK(waitFor([&] { return home.value(base, "SonarRange").has_value(); }, 10s));
  CHECK(numbers(home.value(base, "SonarRange")->data, 100).size() == 8);
  CHECK(home.value(base, "Geometry.radius")->data == "0.2000");
  CHECK(waitFor([&] { return home.value(base, "Battery").has_value(); }, 10s));

  // Drive towards -x (Pippi faces 180 degrees): odometry and the true pose follow.
  const bool moved = waitFor(
      [&] {
        k.set(base, "VelCommand", "0.3 0");
        const auto odometry = numbers(home.value(base, "Odometry")->data, 1);
        return odometry[0] < 3.0;
      },
      60s);
  INFO(home.describe());
  REQUIRE(moved);
  const auto scene = peis::sim::parseScene(home.value(world, "physics.scene")->data);
  for (const auto& r : scene.robots)
    if (r.name == "Pippi") CHECK(r.pose.x < 3.2);

  // A malformed command is refused; the robot keeps going on the last good one.
  REQUIRE_THROWS_MATCHES(k.set(base, "VelCommand", "fast please"), peis::Error,
                         Catch::Matchers::Predicate<peis::Error>(
                             [](const peis::Error& e) {
                               return e.code() == peis::ErrorCode::Refused &&
                                      std::string(e.what()).find("VelCommand takes 'V W'") !=
                                          std::string::npos;
                             },
                             "refused, saying the format"));
  CHECK_THROWS_AS(k.set(base, "Odometry", "0 0 0 0 0"), peis::Error);
  // The world's physics inputs take numbers in range only; its outputs take nothing.
  CHECK_THROWS_AS(k.set(world, "physics.blind.blind.tilt", "150"), peis::Error);
  CHECK_THROWS_AS(k.set(world, "physics.scene", "robot Pippi 0 0 0"), peis::Error);
  k.set(world, "physics.blind.blind.tilt", "0");
  k.subscribe(peis::Pattern("physics.light.*", world));
  CHECK(waitFor(
      [&] {
        const auto plant = home.value(world, "physics.light.plant");
        return plant && numbers(plant->data, 1)[0] < 300;
      },
      20s));

  // Talk wakes Johanna only near the bed: here, far away, it does not.
  k.set(base, "TalkCommand", "wakeup");
  k.subscribe(peis::Pattern("physics.speech", world));
  CHECK(waitFor([&] { return home.value(world, "physics.speech").has_value(); }, 10s));
  CHECK(home.value(world, "physics.speech")->data.find("Pippi") == 0);

  // The picture on request.
  k.subscribe(peis::Pattern("picture", world));
  k.set(world, "picture.request", "now");
  CHECK(waitFor([&] { return home.value(world, "picture").has_value(); }, 20s));
  CHECK(home.value(world, "picture")->mimetype == "image/png");
  CHECK(home.value(world, "picture")->data.substr(1, 3) == "PNG");

  // Without commands the robot stops (cmd_timeout) and the bumper is released.
  REQUIRE(waitFor(
      [&] {
        const auto v = numbers(home.value(base, "Odometry")->data, 5);
        return v.size() == 5 && std::abs(v[3]) < 1e-3;
      },
      20s));
}

TEST_CASE("a run with --duration ends by itself and leaves its top-down picture", "[integration]") {
  Home home;
  auto& world = home.world({"--duration", "1", "--speed", "5"});
  const auto status = world.wait(60s);
  INFO(world.describe());
  REQUIRE(status.has_value());
  CHECK(*status == 0);
  CHECK(world.out().find("duration reached") != std::string::npos);
  std::ifstream picture(home.dir.file("home.png"), std::ios::binary);
  std::string magic(8, '\0');
  picture.read(magic.data(), 8);
  CHECK(magic == "\x89PNG\r\n\x1a\n");
}

TEST_CASE("a physics input follows another PEIS's tuple with --bind", "[integration]") {
  Home home;
  auto& k = home.kernel();  // "referee", the device that reports its lamp level
  k.set("LampLevel", "0");
  home.world({"--bind", "physics.lamp.lamp.level=referee.LampLevel"});
  const auto world = home.idOf("world");
  k.subscribe(peis::Pattern::exact(world, "physics.lamp.lamp.level"));
  k.subscribe(peis::Pattern::exact(world, "physics.light.sofa"));
  REQUIRE(waitFor([&] { return home.value(world, "physics.light.sofa").has_value(); }, 30s));
  const double dark = numbers(home.value(world, "physics.light.sofa")->data, 1)[0];
  k.set("LampLevel", "80");
  const bool followed = waitFor(
      [&] {
        const auto level = home.value(world, "physics.lamp.lamp.level");
        return level && level->data == "80.0";
      },
      30s);
  INFO(home.describe());
  REQUIRE(followed);
  CHECK(waitFor(
      [&] { return numbers(home.value(world, "physics.light.sofa")->data, 1)[0] > dark + 50; }));
  k.set("LampLevel", "bright");  // not a number: ignored, said on stderr
  CHECK(waitFor(
      [&] { return home.processes[0]->err().find("ignored 'bright'") != std::string::npos; }));
  CHECK(home.value(world, "physics.lamp.lamp.level")->data == "80.0");
}

TEST_CASE(
    "world + two cameras + tracker as processes: the tracker's position is within a few cm of the "
    "truth",
    "[integration]") {
  Home home;
  home.world();
  home.camera("living-1");
  home.camera("living-2");
  home.tracker();
  auto& k = home.kernel();
  const auto world = home.idOf("world");
  const auto tracker = home.idOf("tracker");
  const auto camera1 = home.idOf("camera-living-1");
  const auto camera2 = home.idOf("camera-living-2");
  const auto base = home.idOf("Pippi-base");

  // Ground truth by simulated time, from the world's physics.scene.
  std::mutex mu;
  std::map<peis::Timestamp, peis::sim::Pose2> truth;
  k.subscribe(peis::Pattern::exact(world, "physics.scene"));
  k.onChange(peis::Pattern::exact(world, "physics.scene"), [&](const peis::Tuple& t) {
    for (const auto& r : peis::sim::parseScene(t.data).robots)
      if (r.name == "Pippi") {
        std::lock_guard lock(mu);
        truth[t.ts_user] = r.pose;
      }
  });
  std::vector<double> errors;
  std::vector<int> cameraCounts;
  k.subscribe(peis::Pattern::exact(tracker, "position.Pippi"));
  k.onChange(peis::Pattern::exact(tracker, "position.Pippi"), [&](const peis::Tuple& t) {
    const auto v = numbers(t.data, 6);
    std::lock_guard lock(mu);
    const auto at = truth.find(t.ts_user);
    if (v.size() == 6 && at != truth.end()) {
      errors.push_back(std::hypot(v[0] - at->second.x, v[1] - at->second.y));
      cameraCounts.push_back(static_cast<int>(v[5]));
    }
  });

  // Wire the tracker's inputs as a configurator would (meta tuples).
  k.setMeta(tracker, "mi-camera1", camera1, "image");
  k.setMeta(tracker, "mi-camera2", camera2, "image");
  k.subscribe(peis::Pattern::exact(tracker, "status"));
  const bool running = waitFor(
      [&] {
        const auto status = home.value(tracker, "status");
        return status && status->data == "running";
      },
      60s);
  INFO(home.describe());
  REQUIRE(running);

  // Pippi drives a slow arc in the living room; the fixes follow it. Fixes
  // from one camera come too (when the other image is late); both kinds are
  // checked against the truth, the two-camera ones against the target.
  const auto twoCameraFixes = [&] {
    return std::count(cameraCounts.begin(), cameraCounts.end(), 2);
  };
  const bool enough = waitFor(
      [&] {
        k.set(base, "VelCommand", "0.15 0.2");
        std::lock_guard lock(mu);
        return twoCameraFixes() >= 10;
      },
      120s);
  std::lock_guard lock(mu);
  INFO(errors.size() << " fixes, " << twoCameraFixes() << " from two cameras");
  REQUIRE(enough);
  std::vector<double> two;
  for (std::size_t i = 0; i < errors.size(); ++i)
    if (cameraCounts[i] == 2) two.push_back(errors[i]);
  std::sort(two.begin(), two.end());
  INFO("two-camera errors (m): median " << two[two.size() / 2] << ", max " << two.back());
  CHECK(two[two.size() / 2] < 0.03);
  CHECK(two.back() < 0.08);
  CHECK(*std::max_element(errors.begin(), errors.end()) < 0.10);
}

TEST_CASE("the tracker copes with a camera with no image and with tuples that are not images",
          "[fault]") {
  Home home;
  home.world();
  home.camera("living-1");
  home.tracker();
  auto& k = home.kernel();
  const auto tracker = home.idOf("tracker");
  const auto camera1 = home.idOf("camera-living-1");
  // mi-camera2 points at a tuple that never gets a value: a camera with no image.
  k.set("silent.image", "");
  k.erase("silent.image");
  k.setMeta(tracker, "mi-camera1", camera1, "image");
  k.setMeta(tracker, "mi-camera2", k.id(), "silent.image");
  k.subscribe(peis::Pattern("**", tracker));
  // One camera is enough for a (single-camera) fix; the status names the missing input.
  const bool fixed = waitFor(
      [&] {
        const auto p = home.value(tracker, "position.Pippi");
        return p && numbers(p->data, 6).size() == 6 && numbers(p->data, 6)[5] == 1;
      },
      60s);
  INFO(home.describe());
  REQUIRE(fixed);
  CHECK(waitFor([&] {
    const auto status = home.value(tracker, "status");
    const auto cause = home.value(tracker, "cause.names");
    return status && status->data == "waiting" && cause && cause->data == "camera2";
  }));

  // Now camera2 delivers garbage: PNG that is not PNG, raw of the wrong length.
  k.set("fake.calibration",
        "name: fake\nposition: [0.3, 0.3, 2.5]\nlook_at: [2.6, 3.2, 0]\nfx: 380\n",
        peis::WriteOptions{"application/yaml"});
  k.setMeta(tracker, "mi-camera2", k.id(), "fake.image");
  peis::WriteOptions png;
  png.mimetype = "image/png";
  png.encoding = peis::Encoding::Binary;
  peis::WriteOptions raw = png;
  raw.mimetype = "image/x-raw;format=bgr8;width=640;height=480";
  const bool counted = waitFor(
      [&] {
        k.set("fake.image", "\x89PNG but not really", png);
        k.set("fake.image", "short", raw);
        k.set("fake.image", "text", peis::WriteOptions{});
        const auto stats = home.value(tracker, "tracker.stats");
        return stats && stats->data.find("not-images 0 ") == std::string::npos;
      },
      30s);
  REQUIRE(counted);
  // The tracker is alive and still fixes Pippi from the real camera.
  const auto before = home.value(tracker, "position.Pippi")->seqno;
  CHECK(waitFor([&] { return home.value(tracker, "position.Pippi")->seqno > before; }, 30s));
  for (auto& p : home.processes) CHECK(p->running());
}

TEST_CASE("broken world and camera files are errors naming file:line and bad options exit 2",
          "[fault]") {
  peis::test::TempDir dir("peis_home_files");
  const auto expect = [](std::vector<std::string> argv, int status, const std::string& text) {
    Process p(argv, {{"PEIS_DISCOVERY_SCOPE", "off"}});
    const auto code = p.wait(30s);
    INFO(p.describe());
    REQUIRE(code.has_value());
    CHECK(*code == status);
    CHECK(p.err().find(text) != std::string::npos);
  };
  const auto world =
      dir.write("world.yaml", peis::test::boxWorld("  - {name: r1, pose: [9, 1, 0]}\n"));
  expect({program("components/sim/peis-sim-world"), "--world", world}, 1,
         world + ":13: robot r1 pose (9, 1) is outside the map");
  expect({program("components/sim/peis-sim-world"), "--world", dir.file("none.yaml")}, 1,
         "cannot open the world file");
  expect({program("components/sim/peis-sim-world"), "--speed", "0"}, 2, "--speed: takes 0.1..100");
  expect({program("components/sim/peis-sim-world"), "--bind", "physics.sun=7.X"}, 1,
         "--bind physics.sun: not a physics input");
  const auto camera =
      dir.write("camera.yaml", "name: c\nposition: [0, 0, 2.5]\nlook_at: [1, 1, 0]\nfx: [300\n");
  expect({program("components/camera/peis-camera"), "--calibration", camera}, 1,
         camera + ":5: not valid YAML");
  expect({program("components/camera/peis-camera")}, 2, "give --camera NAME or --calibration FILE");
  expect({program("components/camera/peis-camera"), "--camera", "x", "--format", "jpeg"}, 2,
         "takes raw or png");
  const auto targets =
      dir.write("targets.yaml", "targets:\n  - {name: a, colour: [1, 2, 3], height: 1}\n");
  expect({program("components/tracking/peis-tracker"), "--targets", targets}, 1,
         targets + ":2: a hat colour must be saturated");
  expect({program("components/tracking/peis-tracker")}, 2, "--targets is required");
  expect({program("components/tracking/peis-tracker"), "--targets", targets, "--cameras", "0"}, 2,
         "--cameras: takes 1..16");
}
