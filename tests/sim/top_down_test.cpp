// Unit tests of the top-down picture (sim/world/top_down.h).
#include "sim/world/top_down.h"

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>

#include "test_worlds.h"

using namespace peis::sim;

TEST_CASE("the top-down picture is a PNG with the robots' true and estimated poses drawn",
          "[unit]") {
  const World world = loadWorldFile(peis::test::peisHomePath());
  const LightModel light(world);
  Simulation simulation(world, 1);
  const Estimate estimate{"Pippi", "tracker", {1.0, 1.0}, {{1.0, 0.8}, {1.0, 1.0}}};
  const PlannedPath path{"Pippi", "nav", {{3.5, 3.0}, {5.0, 4.0}, {6.6, 4.9}}};
  const std::string png = renderTopDown(simulation, light, {estimate}, {path}, {50, "t=0"});
  const cv::Mat image =
      cv::imdecode(cv::Mat(1, static_cast<int>(png.size()), CV_8UC1, const_cast<char*>(png.data())),
                   cv::IMREAD_COLOR);
  REQUIRE_FALSE(image.empty());
  CHECK(image.cols == 9 * 50 + 60);
  CHECK(image.rows == 6 * 50 + 80);
  // Pippi's hat (blue) at its true pose: x = 30 + 3.5 * 50, y = 50 + (6 - 3) * 50.
  const cv::Vec3b hat = image.at<cv::Vec3b>(50 + 150 - 3, 30 + 175);  // beside the heading line
  CHECK(hat[0] > 150);                                                // blue
  CHECK(hat[2] < 100);
}

TEST_CASE("a camera's field of view is its image border on the floor", "[unit]") {
  const World world = loadWorldFile(peis::test::peisHomePath());
  const auto& c = world.camera("living-1")->calibration;
  const Polygon view = fieldOfView(c);
  REQUIRE(view.size() == 64);
  // The point it looks at is inside its field of view; a point behind it is not.
  CHECK(insidePolygon(view, {2.6, 3.2}));
  CHECK_FALSE(insidePolygon(view, {0.1, 0.1}));
}
