// peis-tracker: camera tracking localization as a PEIS
// (docs/components/tracking.md).
#include <cerrno>
#include <cstdlib>
#include <iostream>
#include <string>

#include "common/command_line.h"
#include "peis/error.h"
#include "peis/options.h"
#include "tracker_node.h"
#include "tracking/targets.h"

namespace {

const char* kUsage =
    "Usage: peis-tracker --targets FILE [options]\n"
    "\n"
    "Camera tracking localization: finds each robot's coloured hat in the images of\n"
    "the cameras its inputs mi-camera1..mi-cameraN point at, triangulates, and\n"
    "publishes position.<robot> = \"X Y VXX VXY VYY CAMERAS\" stamped with the images'\n"
    "time. See docs/components/tracking.md.\n"
    "\n"
    "  --targets FILE       the robots and their hats: a targets file, or a world file\n"
    "                       (its robots' hats)\n"
    "  --cameras N          number of image inputs, 1..16 (default 2)\n"
    "  --pixel-sigma PX     centroid uncertainty for the covariance (default 1.0)\n"
    "  --height-sigma M     uncertainty of a hat's height (default 0.03)\n"
    "  --gate M             a ray farther than this from the others is dropped (default 0.15)\n"
    "  --min-area PX        smallest hat blob (default 12)\n"
    "  --min-saturation S   0..255 (default 100)\n"
    "  --min-value V        0..255 (default 25)\n"
    "  --hue-tolerance H    OpenCV hue units, 1..45 (default 8)\n"
    "  --freshness-ms N     an input with no image for this long is not waited for\n"
    "                       and shows in cause.names (default 2000)\n"
    "  --wait-ms N          wait this long for the other cameras' images of a moment\n"
    "                       (default 150)\n"
    "  --max-skew-ms N      images this close in time are one moment (default 50)\n"
    "  --cost C             the functionality's cost for the configuration planner\n"
    "                       (default 2; a spare tracker is declared dearer)\n"
    "  --help               this text\n"
    "\n"
    "The PEIS is named 'tracker' unless --peis-name says otherwise.\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace peis::components;
  peis::tracking::TrackerConfig config;
  if (auto done = parsePeisOptions(argc, argv, "peis-tracker", kUsage, "tracker", config.peis))
    return *done;
  std::string targetsPath;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const char* value = i + 1 < argc ? argv[i + 1] : nullptr;
    double n = 0;
    auto bad = [&](const std::string& why) { return badArgument("peis-tracker", arg, why); };
    const auto ms = [&](double high) { return parseNumber(value, 1, high, &n); };
    if (arg == "--targets" && value != nullptr) {
      targetsPath = value;
    } else if (arg == "--cameras" && value != nullptr) {
      if (!parseNumber(value, 1, 16, &n) || n != static_cast<int>(n)) return bad("takes 1..16");
      config.cameras = static_cast<int>(n);
    } else if (arg == "--pixel-sigma" && value != nullptr) {
      if (!parseNumber(value, 0.01, 100, &config.noise.pixelSigma)) return bad("takes 0.01..100");
    } else if (arg == "--height-sigma" && value != nullptr) {
      if (!parseNumber(value, 0.001, 10, &config.noise.heightSigma)) return bad("takes 0.001..10");
    } else if (arg == "--gate" && value != nullptr) {
      if (!parseNumber(value, 0.001, 100, &config.noise.gate)) return bad("takes 0.001..100");
    } else if (arg == "--min-area" && value != nullptr) {
      if (!parseNumber(value, 1, 1e6, &n)) return bad("takes 1..1000000");
      config.detector.minArea = static_cast<int>(n);
    } else if (arg == "--min-saturation" && value != nullptr) {
      if (!parseNumber(value, 0, 255, &n)) return bad("takes 0..255");
      config.detector.minSaturation = static_cast<int>(n);
    } else if (arg == "--min-value" && value != nullptr) {
      if (!parseNumber(value, 0, 255, &n)) return bad("takes 0..255");
      config.detector.minValue = static_cast<int>(n);
    } else if (arg == "--hue-tolerance" && value != nullptr) {
      if (!parseNumber(value, 1, 45, &config.detector.hueTolerance)) return bad("takes 1..45");
    } else if (arg == "--freshness-ms" && value != nullptr) {
      if (!ms(3600000)) return bad("takes 1..3600000");
      config.freshness = std::chrono::milliseconds(static_cast<long>(n));
    } else if (arg == "--wait-ms" && value != nullptr) {
      if (!ms(60000)) return bad("takes 1..60000");
      config.wait = std::chrono::milliseconds(static_cast<long>(n));
    } else if (arg == "--max-skew-ms" && value != nullptr) {
      if (!ms(60000)) return bad("takes 1..60000");
      config.maxSkew = std::chrono::microseconds(static_cast<long>(n * 1000));
    } else if (arg == "--cost" && value != nullptr) {
      if (!parseNumber(value, 0, 1e6, &n)) return bad("takes 0..1000000");
      config.cost = n;
    } else {
      return bad(unknownArgument(arg, value));
    }
    ++i;
  }
  if (targetsPath.empty()) {
    std::cerr << "peis-tracker: --targets is required (see --help)\n";
    return 2;
  }
  try {
    config.targets = peis::tracking::loadTargets(targetsPath);
    peis::tracking::TrackerNode node(std::move(config));
    std::cerr << "peis-tracker: PEIS " << node.kernel().id() << " '" << node.kernel().name()
              << "' on port " << node.kernel().port() << std::endl;
    const std::string why = node.run();
    const auto s = node.stats();
    std::cerr << "peis-tracker: " << why << "; images " << s.images << ", not images "
              << s.notImages << ", without calibration " << s.noCalibration << ", wrong size "
              << s.wrongSize << ", fixes " << s.fixes << std::endl;
    return 0;
  } catch (const peis::Error& e) {
    std::cerr << "peis-tracker: " << e.what() << "\n";
    return 1;
  }
}
