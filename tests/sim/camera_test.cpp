// Unit tests of the camera model (camera/calibration.h, image_tuple.h) and
// the simulated camera's renderer (camera/render_view.h).
#include <catch2/catch.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/calibration.h"
#include "camera/image_tuple.h"
#include "camera/render_view.h"
#include "common/yaml_reader.h"
#include "peis/error.h"
#include "sim/world/scene.h"
#include "support/temp_dir.h"
#include "test_worlds.h"

using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using namespace peis;

namespace {

camera::Calibration overhead() {
  camera::Calibration c;
  c.name = "test";
  c.position = {1, 2, 3};
  c.rotation = camera::lookAtRotation(c.position, {2, 3, 0}, {0, 0, 1});
  return c;
}

}  // namespace

TEST_CASE("a camera projects what it looks at to its principal point, and rays invert projection",
          "[unit]") {
  const auto c = overhead();
  const auto centre = c.project({2, 3, 0});
  REQUIRE(centre);
  CHECK(centre->x() == Approx(c.cx));
  CHECK(centre->y() == Approx(c.cy));
  CHECK_FALSE(c.project({0, 1, 4}));  // behind
  for (const auto& [u, v] :
       {std::pair{10.0, 20.0}, std::pair{600.0, 400.0}, std::pair{320.0, 5.0}}) {
    const auto floor = c.intersectHeight(u, v, 0.4);
    REQUIRE(floor);
    CHECK(floor->z() == Approx(0.4));
    const auto back = c.project(*floor);
    REQUIRE(back);
    CHECK(back->x() == Approx(u));
    CHECK(back->y() == Approx(v));
  }
  // The image's up points to the world's up: a higher point is higher in the image.
  CHECK(c.project({2, 3, 1})->y() < centre->y());
  CHECK_THROWS_AS(camera::lookAtRotation({0, 0, 3}, {0, 0, 0}, {0, 0, 1}), std::invalid_argument);
}

TEST_CASE("a calibration round-trips through its YAML", "[unit]") {
  const auto c = overhead();
  const auto back = camera::calibrationFromYaml(c.toYaml(), "calibration");
  CHECK(back.name == "test");
  CHECK(back.width == 640);
  CHECK((back.position - c.position).norm() < 1e-6);
  CHECK((back.rotation - c.rotation).norm() < 1e-6);
  CHECK(back.fx == Approx(c.fx));
}

TEST_CASE("broken camera files name file:line and the problem", "[unit]") {
  test::TempDir dir("camera");
  const auto errorOf = [&](const std::string& text) -> std::string {
    const auto path = dir.write("cam.yaml", text);
    try {
      camera::cameraFromFile(path);
    } catch (const Error& e) {
      CHECK(e.code() == ErrorCode::InvalidConfig);
      return std::string(e.what()).substr(path.size() - 8);  // from "cam.yaml"
    }
    return "no error";
  };
  CHECK_THAT(errorOf("name: c\nposition: [0, 0, [\n"), StartsWith("cam.yaml:3: not valid YAML"));
  CHECK_THAT(errorOf("name: c\nposition: [0, 0, 2]\nlook_at: [1, 0, 0]\nfx: 300\nzoom: 2\n"),
             StartsWith("cam.yaml:5: unknown key 'zoom' in a camera"));
  CHECK_THAT(errorOf("name: c\nposition: [0, 0, 2]\nlook_at: [0, 0, 0]\nfx: 300\n"),
             StartsWith("cam.yaml:3: camera look_at: up is along the viewing direction"));
  CHECK_THAT(
      errorOf("name: c\nposition: [0, 0, 2]\nrotation: [1, 0, 0, 0, 1, 0, 0, 0, 2]\nfx: 300\n"),
      StartsWith("cam.yaml:3: camera rotation must be a rotation matrix"));
  CHECK_THAT(errorOf("name: c\nposition: [0, 0, 2]\nlook_at: [1, 0, 0]\nfx: -5\n"),
             StartsWith("cam.yaml:4: camera fx must be in 1..1e+06, not -5"));
  CHECK_THAT(errorOf("name: c\nposition: [0, 0, 2]\nlook_at: [1, 0, 0]\n"),
             StartsWith("cam.yaml:1: a camera (or fov_deg) needs 'fx'"));
  CHECK_THAT(errorOf("[1, 2]\n"),
             StartsWith("cam.yaml:1: a camera file must be one camera mapping"));
  const auto spec = camera::cameraFromYaml(
      components::YamlReader("x"), YAML::Load("{name: c, position: [0, 0, 2], look_at: [1, 0, 0], "
                                              "fov_deg: 90, width: 320, height: 240}"));
  CHECK(spec.calibration.fx == Approx(160.0));
  CHECK(spec.calibration.cx == Approx(159.5));
  CHECK_THROWS_WITH(camera::cameraFromFile(dir.file("none.yaml")),
                    Contains("cannot open the camera file"));
}

TEST_CASE("images round-trip as PNG and raw tuples and anything else is refused with a reason",
          "[unit]") {
  cv::Mat image(48, 64, CV_8UC3);
  cv::randu(image, 0, 255);
  for (const auto format : {camera::ImageFormat::Png, camera::ImageFormat::Raw}) {
    const auto encoded = camera::encodeImage(image, format);
    std::string why;
    const cv::Mat back = camera::decodeImage(encoded.mimetype, encoded.data, why);
    REQUIRE(why.empty());
    CHECK(cv::norm(back, image, cv::NORM_INF) == 0);
  }
  CHECK(camera::encodeImage(image, camera::ImageFormat::Raw).mimetype ==
        "image/x-raw;format=bgr8;width=64;height=48");
  std::string why;
  CHECK(camera::decodeImage("image/png", "not a png at all, just text", why).empty());
  CHECK_THAT(why, Contains("not a PNG image"));
  why.clear();
  CHECK(camera::decodeImage("image/x-raw;format=bgr8;width=64;height=48", "short", why).empty());
  CHECK_THAT(why, Contains("must be 9216 bytes, not 5"));
  why.clear();
  CHECK(camera::decodeImage("image/x-raw;format=rgb16;width=2;height=2", "12345678", why).empty());
  CHECK_THAT(why, Contains("needs format=bgr8|mono8"));
  why.clear();
  CHECK(camera::decodeImage("text/plain", "hello", why).empty());
  CHECK_THAT(why, Contains("not an image this reader accepts"));
  // A PNG header that claims 100000 x 100000 pixels is refused before decoding.
  auto png = camera::encodeImage(image, camera::ImageFormat::Png).data;
  png[16] = 0, png[17] = 1, png[18] = static_cast<char>(0x86), png[19] = static_cast<char>(0xa0);
  why.clear();
  CHECK(camera::decodeImage("image/png", png, why).empty());
  CHECK_THAT(why, Contains("at most 8192 x 8192"));
  // A PNG whose data is cut off.
  why.clear();
  const auto whole = camera::encodeImage(image, camera::ImageFormat::Png).data;
  CHECK(camera::decodeImage("image/png", whole.substr(0, whole.size() / 2), why).empty());
  // Grey raw images come back as BGR.
  cv::Mat grey(4, 4, CV_8UC1, cv::Scalar(77));
  const auto g = camera::encodeImage(grey, camera::ImageFormat::Raw);
  why.clear();
  const cv::Mat bgr = camera::decodeImage(g.mimetype, g.data, why);
  CHECK(bgr.type() == CV_8UC3);
  CHECK(bgr.at<cv::Vec3b>(1, 1) == cv::Vec3b(77, 77, 77));
}

TEST_CASE(
    "the rendered view shows a robot's hat where the calibration projects it, lit by the light "
    "model",
    "[unit]") {
  const auto world = sim::loadWorldFile(test::peisHomePath());
  const sim::LightModel light(world);
  sim::Simulation simulation(world, 1);
  const sim::Scene scene = sim::sceneOf(simulation);
  const auto& spec = *world.camera("living-1");
  const cv::Mat image = camera::renderView(world, light, scene, spec, 5);
  REQUIRE(image.cols == 640);
  REQUIRE(image.rows == 480);
  const sim::Robot& pippi = *world.robot("Pippi");
  const auto pixel = spec.calibration.project({pippi.start.x, pippi.start.y, pippi.hatTop()});
  REQUIRE(pixel);
  REQUIRE(spec.calibration.inImage(*pixel));
  cv::Mat hsv;
  cv::cvtColor(image, hsv, cv::COLOR_BGR2HSV);
  const cv::Vec3b at = hsv.at<cv::Vec3b>(static_cast<int>(std::lround(pixel->y())),
                                         static_cast<int>(std::lround(pixel->x())));
  CHECK(std::abs(at[0] - 114) < 6);  // blue: hue 228 degrees
  CHECK(at[1] > 150);

  // Closing the blind darkens the picture; the lamp brightens it again.
  sim::Scene dark = scene;
  dark.blinds = {{"blind", 0}};
  const double open = camera::meanBrightness(image);
  const double closed = camera::meanBrightness(camera::renderView(world, light, dark, spec, 5));
  dark.lamps = {{"lamp", 100}};
  const double lamp = camera::meanBrightness(camera::renderView(world, light, dark, spec, 5));
  CHECK(closed < open * 0.5);
  CHECK(lamp > closed);
}
