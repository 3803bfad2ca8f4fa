// peis-camera: a simulated ceiling camera as a PEIS (docs/components/camera.md).
#include <cerrno>
#include <cstdlib>
#include <iostream>
#include <string>

#include "camera_node.h"
#include "common/command_line.h"
#include "peis/error.h"
#include "peis/options.h"

namespace {

const char* kUsage =
    "Usage: peis-camera (--camera NAME | --calibration FILE) [options]\n"
    "\n"
    "A simulated ceiling camera: renders what it sees of the simulated home from its\n"
    "pose and intrinsics (floor, furniture, robots and their hats, lighting, sensor\n"
    "noise) and publishes `image` and `calibration`. See docs/components/camera.md.\n"
    "\n"
    "  --camera NAME        a camera of the world file (read from the world PEIS)\n"
    "  --calibration FILE   a camera file (one camera mapping); its name is the camera's\n"
    "  --world PEIS         the world PEIS, a name or an id (default world)\n"
    "  --rate HZ            images per second of simulated time, 0.1..200\n"
    "                       (default: the camera's rate_hz, else 10)\n"
    "  --format raw|png     image/x-raw;format=bgr8;... (default) or image/png\n"
    "  --noise SIGMA        sensor noise in grey levels, 0..100 (default: the camera's, else 2)\n"
    "  --seed N             seed of the noise (default 1)\n"
    "  --help               this text\n"
    "\n"
    "The PEIS is named camera-NAME unless --peis-name says otherwise.\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace peis::components;
  peis::camera::CameraConfig config;
  if (auto done = parsePeisOptions(argc, argv, "peis-camera", kUsage, "", config.peis))
    return *done;
  std::string calibrationPath;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const char* value = i + 1 < argc ? argv[i + 1] : nullptr;
    double n = 0;
    auto bad = [&](const std::string& why) { return badArgument("peis-camera", arg, why); };
    if (arg == "--camera" && value != nullptr) {
      config.camera = value;
    } else if (arg == "--calibration" && value != nullptr) {
      calibrationPath = value;
    } else if (arg == "--world" && value != nullptr) {
      config.world = value;
    } else if (arg == "--rate" && value != nullptr) {
      if (!parseNumber(value, 0.1, 200, &n)) return bad("takes 0.1..200");
      config.rateHz = n;
    } else if (arg == "--noise" && value != nullptr) {
      if (!parseNumber(value, 0, 100, &n)) return bad("takes 0..100");
      config.noise = n;
    } else if (arg == "--format" && value != nullptr) {
      const std::string format = value;
      if (format == "raw")
        config.format = peis::camera::ImageFormat::Raw;
      else if (format == "png")
        config.format = peis::camera::ImageFormat::Png;
      else
        return bad("takes raw or png");
    } else if (arg == "--seed" && value != nullptr) {
      if (!parseNumber(value, 0, 1e15, &n)) return bad("takes an integer >= 0");
      config.seed = static_cast<std::uint64_t>(n);
    } else {
      return bad(unknownArgument(arg, value));
    }
    ++i;
  }
  if (config.camera.empty() == calibrationPath.empty()) {
    std::cerr << "peis-camera: give --camera NAME or --calibration FILE (see --help)\n";
    return 2;
  }
  try {
    if (!calibrationPath.empty()) {
      config.calibration = peis::camera::cameraFromFile(calibrationPath);
      config.camera = config.calibration->calibration.name;
    }
    if (config.peis.name.empty() || config.peis.name == config.peis.programName)
      config.peis.name = "camera-" + config.camera;
    peis::camera::CameraNode node(std::move(config));
    std::cerr << "peis-camera: PEIS " << node.kernel().id() << " '" << node.kernel().name()
              << "' on port " << node.kernel().port() << std::endl;
    const std::string why = node.run();
    std::cerr << "peis-camera: " << why << "; " << node.framesPublished() << " images" << std::endl;
    return 0;
  } catch (const peis::Error& e) {
    std::cerr << "peis-camera: " << e.what() << "\n";
    return 1;
  }
}
