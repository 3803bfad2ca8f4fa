// Unit tests of camera tracking (components/tracking): targets, hat
// detection on rendered images with known ground truth, triangulation with
// two cameras, the ground-plane fix with one, nothing with none.
#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <cmath>

#include "camera/render_view.h"
#include "peis/error.h"
#include "sim/world/scene.h"
#include "test_worlds.h"
#include "tracking/hat_detector.h"
#include "tracking/targets.h"
#include "tracking/triangulation.h"

using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using namespace peis;

namespace {

struct Home {
  sim::World world = sim::loadWorldFile(test::peisHomePath());
  sim::LightModel light{world};
  std::vector<tracking::Target> targets = tracking::loadTargets(test::peisHomePath());

  // The scene with robot `name` moved to `pose`.
  sim::Scene sceneWith(const std::string& name, sim::Pose2 pose) const {
    sim::Simulation simulation(world, 1);
    sim::Scene scene = sim::sceneOf(simulation);
    for (auto& r : scene.robots)
      if (r.name == name) r.pose = pose;
    return scene;
  }
  std::size_t targetIndex(const std::string& name) const {
    for (std::size_t i = 0; i < targets.size(); ++i)
      if (targets[i].name == name) return i;
    FAIL("no target " << name);
    return 0;
  }
  // Sightings of `name` in the images of the named cameras.
  std::vector<tracking::Sighting> sightings(const sim::Scene& scene, const std::string& name,
                                            const std::vector<std::string>& cameras) const {
    std::vector<tracking::Sighting> found;
    tracking::HatDetector detector(targets);
    for (const auto& cameraName : cameras) {
      const auto* spec = world.camera(cameraName);
      const cv::Mat image = camera::renderView(world, light, scene, *spec, 11);
      for (const auto& d : detector.detect(image))
        if (d.target == targetIndex(name)) found.push_back({&spec->calibration, d.u, d.v});
    }
    return found;
  }
};

double errorOf(const tracking::Fix& fix, sim::Pose2 truth) {
  return std::hypot(fix.point.x() - truth.x, fix.point.y() - truth.y);
}

}  // namespace

TEST_CASE("targets come from a world file's robots or from a targets file", "[unit]") {
  const auto targets = tracking::loadTargets(test::peisHomePath());
  REQUIRE(targets.size() == 4);
  CHECK(targets[1].name == "Pippi");
  CHECK(targets[1].height == Approx(0.51));
  CHECK(targets[1].hue == Approx(tracking::hueOf(40, 70, 220)));
  CHECK(tracking::hueOf(255, 0, 0) == 0);
  CHECK(tracking::hueOf(0, 0, 255) == 120);
  const auto own = tracking::parseTargets(
      "targets:\n  - {name: a, colour: [255, 0, 0], height: 0.4}\n", "t.yaml");
  CHECK(own[0].height == 0.4);
  const auto errorOf = [](const std::string& text) -> std::string {
    try {
      tracking::parseTargets(text, "t.yaml");
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  };
  CHECK_THAT(errorOf("targets:\n  - {name: a, colour: [128, 128, 128], height: 0.4}\n"),
             StartsWith("t.yaml:2: a hat colour must be saturated"));
  CHECK_THAT(errorOf("targets:\n  - {name: a, colour: [255, 0, 0]}\n"),
             StartsWith("t.yaml:2: a target needs 'height'"));
  CHECK_THAT(errorOf("cameras: []\n"), StartsWith("t.yaml:1: a targets file needs 'targets'"));
  CHECK_THAT(errorOf("targets: [\n"), StartsWith("t.yaml:2: not valid YAML"));
}

TEST_CASE("the detector finds a hat at the projection of its centre in a rendered image",
          "[unit]") {
  const Home home;
  const sim::Pose2 truth{2.0, 2.5, 0.3};
  const auto scene = home.sceneWith("Pippi", truth);
  const auto* spec = home.world.camera("living-1");
  tracking::HatDetector detector(home.targets);
  const auto detections =
      detector.detect(camera::renderView(home.world, home.light, scene, *spec, 3));
  const auto pixel =
      spec->calibration.project({truth.x, truth.y, home.targets[home.targetIndex("Pippi")].height});
  REQUIRE(pixel);
  bool seen = false;
  for (const auto& d : detections)
    if (d.target == home.targetIndex("Pippi")) {
      seen = true;
      CHECK(std::hypot(d.u - pixel->x(), d.v - pixel->y()) < 1.5);
      CHECK(d.area > 50);
    }
  CHECK(seen);
  // Nothing else in the home is taken for a hat: at most one detection per robot in view.
  CHECK(detections.size() <= home.targets.size());
  CHECK(detector.detect(cv::Mat()).empty());
  CHECK(detector.detect(cv::Mat(480, 640, CV_8UC3, cv::Scalar(128, 128, 128))).empty());
}

TEST_CASE("two cameras triangulate a robot within 2 cm of the truth", "[unit]") {
  const Home home;
  const double height = home.targets[home.targetIndex("Pippi")].height;
  for (const sim::Pose2 truth :
       {sim::Pose2{2.0, 2.5, 0}, sim::Pose2{1.2, 1.8, 1}, sim::Pose2{3.4, 3.6, 2}}) {
    const auto scene = home.sceneWith("Pippi", truth);
    const auto seen = home.sightings(scene, "Pippi", {"living-1", "living-2"});
    REQUIRE(seen.size() == 2);
    const auto fix = tracking::triangulate(seen, height, {});
    REQUIRE(fix);
    CHECK(fix->cameras == 2);
    CHECK(errorOf(*fix, truth) < 0.02);
    CHECK(fix->point.z() == Approx(height).margin(0.03));
    CHECK(fix->covariance(0, 0) > 0);
    CHECK(fix->covariance.determinant() > 0);
  }
}

TEST_CASE("one camera gives a ground-plane fix with a larger covariance and none gives nothing",
          "[unit]") {
  const Home home;
  const double height = home.targets[home.targetIndex("Pippi")].height;
  const sim::Pose2 truth{2.0, 2.5, 0};
  const auto scene = home.sceneWith("Pippi", truth);
  const auto both = home.sightings(scene, "Pippi", {"living-1", "living-2"});
  const auto one = home.sightings(scene, "Pippi", {"living-1"});
  REQUIRE(one.size() == 1);
  const auto fix2 = tracking::triangulate(both, height, {});
  const auto fix1 = tracking::triangulate(one, height, {});
  REQUIRE(fix1);
  REQUIRE(fix2);
  CHECK(fix1->cameras == 1);
  CHECK(errorOf(*fix1, truth) < 0.03);
  CHECK(fix1->covariance.trace() > fix2->covariance.trace());
  CHECK_FALSE(tracking::triangulate({}, height, {}));

  // Here in the bedroom the wall hides the robot from the living-room
  // cameras; the bedroom camera alone sees it.
  const sim::Pose2 hidden{7.5, 3.2, 0};
  const auto bedroom = home.sceneWith("Pippi", hidden);
  CHECK(home.sightings(bedroom, "Pippi", {"living-1", "living-2"}).empty());
  const auto seen = home.sightings(bedroom, "Pippi", {"bedroom"});
  REQUIRE(seen.size() == 1);
  const auto fix = tracking::triangulate(seen, height, {});
  REQUIRE(fix);
  CHECK(errorOf(*fix, hidden) < 0.05);
}

TEST_CASE("a sighting that disagrees with the others is dropped", "[unit]") {
  const Home home;
  const double height = 0.52;
  const auto& c1 = home.world.camera("living-1")->calibration;
  const auto& c2 = home.world.camera("living-2")->calibration;
  const auto& c3 = home.world.camera("bedroom")->calibration;
  const Eigen::Vector3d truth(2.5, 3.0, height);
  const auto p1 = c1.project(truth), p2 = c2.project(truth);
  REQUIRE(p1);
  REQUIRE(p2);
  const auto wrong = c3.project({6.5, 4.0, height});  // something else, elsewhere
  REQUIRE(wrong);
  const auto fix = tracking::triangulate(
      {{&c1, p1->x(), p1->y()}, {&c2, p2->x(), p2->y()}, {&c3, wrong->x(), wrong->y()}}, height,
      {});
  REQUIRE(fix);
  CHECK(fix->cameras == 2);
  CHECK((fix->point - truth).norm() < 1e-6);
  // Two cameras that disagree: no way to tell which is right, so no fix.
  CHECK_FALSE(
      tracking::triangulate({{&c1, p1->x(), p1->y()}, {&c3, wrong->x(), wrong->y()}}, height, {}));
}
