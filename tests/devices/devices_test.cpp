// The home's devices, their pure parts: phrases and WAV durations (talk),
// photos and their measured brightness (photo camera), the tiny nodes'
// sensor file (sim sensors).
#include <catch2/catch.hpp>
#include <cstdint>
#include <fstream>
#include <sstream>

#include "photo.h"
#include "sensor_file.h"
#include "speech.h"
#include "support/temp_dir.h"

using namespace peis::devices;

namespace {

std::string wav(std::uint32_t byteRate, std::uint32_t dataBytes, std::uint32_t declared) {
  auto le32 = [](std::uint32_t v) {
    return std::string{char(v & 0xff), char((v >> 8) & 0xff), char((v >> 16) & 0xff),
                       char(v >> 24)};
  };
  std::string fmt = std::string("\x01\x00\x01\x00", 4) + le32(byteRate / 2) + le32(byteRate) +
                    std::string("\x02\x00\x10\x00", 4);
  return "RIFF" + le32(36 + dataBytes) + "WAVE" + "fmt " + le32(16) + fmt + "data" +
         le32(declared) + std::string(dataBytes, '\0');
}

}  // namespace

TEST_CASE("phrases: the scenario's wakeup, added ones, and plain words", "[unit]") {
  PhraseTable phrases;
  CHECK(phrases.words("wakeup") == "Good morning, Johanna. Time to wake up.");
  phrases.add("dinner=Dinner is ready.");
  CHECK(phrases.words("dinner") == "Dinner is ready.");
  CHECK(phrases.words("good-night") == "good night");
  CHECK_THROWS_AS(phrases.add("nothing"), std::invalid_argument);
  CHECK_THROWS_AS(phrases.add("=x"), std::invalid_argument);
}

TEST_CASE("WAV durations come from the header, and bad files are named", "[unit]") {
  CHECK(*wavSeconds(wav(44100, 88200, 88200)) == Approx(2.0));
  CHECK(*wavSeconds(wav(44100, 4410, 0x7fffffff)) == Approx(0.1));  // streamed: size unknown
  std::string why;
  CHECK_FALSE(wavSeconds("not a wav", &why));
  CHECK(why == "not a RIFF/WAVE file");
  std::string noData = wav(44100, 0, 0);
  noData.resize(noData.size() - 8);
  CHECK_FALSE(wavSeconds(noData, &why));
  CHECK(why == "no data chunk");
  CHECK_FALSE(wavSeconds(wav(0, 10, 10), &why));
  CHECK(why == "byte rate 0");
}

TEST_CASE("a photo's measured brightness follows the light on the region", "[unit]") {
  const std::array<int, 3> sofa{120, 105, 100};
  PhotoSettings settings;
  const double dark = measureBrightness(takePhoto(sofa, 30, settings, 1));
  const double lit = measureBrightness(takePhoto(sofa, 300, settings, 2));
  const double half = measureBrightness(takePhoto(sofa, 150, settings, 3));
  CHECK(dark < 20);
  CHECK(lit > 90);
  CHECK(half == Approx(lit / 2).epsilon(0.1));
  const cv::Mat photo = takePhoto(sofa, 300, settings, 4);
  CHECK(photo.cols == 320);
  CHECK(photo.rows == 240);
  const std::string png = encodePng(photo);
  CHECK(png.substr(1, 3) == "PNG");
  CHECK_THROWS_AS(measureBrightness(cv::Mat()), std::invalid_argument);
}

TEST_CASE("the tiny nodes' sensor file: light levels, weights, atomic writes", "[unit]") {
  CHECK(lightLevel(1400, 2) == 700);
  CHECK(lightLevel(1e6, 2) == 1000);
  CHECK(lightLevel(-3, 2) == 0);
  CHECK(lightLevel(100, 0) == 0);
  CHECK(weightGrams("2.2000 3.2000 0.00000 2.5") == 2500);
  CHECK_FALSE(weightGrams("2.2 3.2 0"));
  CHECK_FALSE(weightGrams("2.2 3.2 0 heavy"));
  CHECK_FALSE(weightGrams("2.2 3.2 0 -1"));
  CHECK(formatSensorFile({700, std::nullopt}) == "light 700\n");
  CHECK(formatSensorFile({700, 2500}) == "light 700\nweight 2500\n");
  peis::test::TempDir dir;
  const std::string path = dir.file("plant.sensors");
  REQUIRE(writeAtomically(path, "light 12\n"));
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  CHECK(text.str() == "light 12\n");
  CHECK_FALSE(writeAtomically(dir.file("no/such/dir/file"), "x"));
}

#include "coverage.h"

TEST_CASE("coverage lanes cover a room's free cells in alternating directions", "[unit]") {
  peis::nav::OccupancyGrid grid(peis::nav::GridInfo{0.05, 0, 0, 60, 40});  // 3 x 2 m, no walls
  grid.setOccupied({30, 20}, true);                                        // a post in the middle
  const peis::nav::Costmap costmap(grid, peis::nav::InflationOptions{0.15, 0.0, 0.0, 0.0});
  const auto room = parsePolygon("0 0 3 0 3 2 0 2");
  REQUIRE(room);
  const auto waypoints = coverageWaypoints(costmap, *room, 0.3);
  REQUIRE(waypoints.size() >= 12);
  for (const auto& p : waypoints) REQUIRE_FALSE(costmap.lethal(grid.cellOf(p)));
  CHECK(waypoints[0].x < waypoints[1].x);  // first lane left to right
  CHECK(waypoints[2].x > waypoints[3].x);  // second lane right to left
  // Every free cell of the room is within a lane spacing of a lane.
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 60; ++x) {
      const auto p = grid.centreOf({x, y});
      if (costmap.lethal({x, y})) continue;
      double nearest = 1e9;
      for (std::size_t i = 0; i + 1 < waypoints.size(); ++i)
        if (waypoints[i].y == waypoints[i + 1].y)
          nearest = std::min(nearest, std::abs(p.y - waypoints[i].y));
      REQUIRE(nearest <= 0.3);
    }
  CHECK(insidePolygon(*room, {1, 1}));
  CHECK_FALSE(insidePolygon(*room, {4, 1}));
  CHECK_FALSE(parsePolygon("0 0 1 1"));
  CHECK_FALSE(parsePolygon("0 0 1 1 2"));
  CHECK(coverageWaypoints(costmap, {}, 0.3).empty());
}

TEST_CASE("push light obstacles, avoid heavy ones and ones of unknown weight", "[unit]") {
  CHECK(decideObstacle(800, 1.0).push);
  CHECK(decideObstacle(800, 1.0).reason == "push: 800 g <= 1000 g");
  CHECK_FALSE(decideObstacle(2500, 1.0).push);
  CHECK(decideObstacle(2500, 1.0).reason == "avoid: 2500 g > 1000 g");
  CHECK_FALSE(decideObstacle(std::nullopt, 1.0).push);
  CHECK(decideObstacle(std::nullopt, 1.0).reason == "avoid: weight unknown");
}
