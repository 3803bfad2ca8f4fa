// peis-photo-camera: a camera that takes a photo of a region of the home on
// request (ExecGoal Photo(sofa)), publishes it (`photo`, image/png) with the
// brightness measured from its pixels (`photo.brightness`), and reports
// success, or failure "too dark" below --min-brightness (Astrid's photo of the
// sofa, tiny-peis-kernel.txt V). A simulated sensor: it reads the light at
// the region from the world's physics channel (physics.light.<region>) and
// the region's colour from physics.world. docs/components/photo-camera.md.
#include <peis/component.h>
#include <yaml-cpp/yaml.h>

#include <iostream>

#include "execution/exec_server.h"
#include "execution/program_options.h"
#include "photo.h"
#include "photo_camera_descriptor.h"

namespace {

const char* kUsage = R"usage(Usage: peis-photo-camera [OPTIONS] [--peis-* flags]

Takes a photo of a region on request: ExecGoal Photo(sofa) publishes photo
(image/png) and photo.brightness (mean grey 0..255), and ExecStatus success, or
failed "too dark" when the brightness is below --min-brightness.

Options:
  --world NAME          the simulated world PEIS (default: world)
  --min-brightness B    0..255 (default 90)
  --full-exposure LUX   lux at which a region shows its full colour (default 300)
  --robot NAME          the robot the camera is on: its photos are image(NAME) to
                        the configuration planner (default: this PEIS's name)
  --help                this text
)usage";

// The colour of a furniture, object or room named `name` in the world file.
std::optional<std::array<int, 3>> colourOf(const std::string& worldYaml, const std::string& name) {
  try {
    const YAML::Node world = YAML::Load(worldYaml);
    for (const char* section : {"furniture", "objects", "rooms"})
      for (const auto& item : world[section])
        if (item["name"] && item["name"].as<std::string>() == name && item["colour"] &&
            item["colour"].size() == 3)
          return std::array<int, 3>{item["colour"][0].as<int>(), item["colour"][1].as<int>(),
                                    item["colour"][2].as<int>()};
  } catch (const YAML::Exception&) {
  }
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  if (peis::exec::printedHelp(argc, argv, kUsage)) return 0;
  peis::Kernel kernel(argc, argv);
  std::string worldName = "world";
  std::string robot;
  double minBrightness = 90;
  peis::devices::PhotoSettings settings;
  const int code = peis::exec::parseProgramOptions(
      argc, argv, "peis-photo-camera", kUsage,
      [&](const std::string& name, const std::string& value) {
        const auto number = peis::exec::parseNumber(value);
        if (name == "--world")
          worldName = value;
        else if (name == "--min-brightness" && number && *number >= 0 && *number <= 255)
          minBrightness = *number;
        else if (name == "--full-exposure" && number && *number > 0)
          settings.fullExposureLux = *number;
        else if (name == "--robot" && !value.empty() && value[0] != '?' &&
                 peis::Term::parse("image(" + value + ")"))
          robot = value;
        else
          return false;
        return true;
      });
  if (code >= 0) return code;
  peis::Descriptor descriptor =
      peis::Descriptor::fromYaml(kPhotoCameraDescriptor, "photo_camera.yaml");
  if (!robot.empty()) {  // image(?self) -> image(astrid)
    for (auto& f : descriptor.functionalities)
      for (auto& port : f.outputs)
        if (const auto at = port.type.find("?self"); at != std::string::npos)
          port.type.replace(at, 5, robot);
  }
  peis::Component component(kernel, "photo-camera", descriptor);
  peis::PeisId world = 0;
  std::uint32_t shots = 0;
  std::unique_ptr<peis::exec::ExecServer> server;
  // Takes the photo; a reading not there yet is waited for (attemptsLeft × 200 ms).
  std::function<void(const peis::exec::Action&, std::uint64_t, int)> shoot =
      [&](const peis::exec::Action& a, std::uint64_t id, int attemptsLeft) {
        const std::string region = a.args[0];
        auto failed = [&](const std::string& cause) {
          server->publish({peis::exec::ExecState::Failed, id, a.toString(), cause});
        };
        const auto light = world ? kernel.get(world, "physics.light." + region) : std::nullopt;
        const auto lux = light ? peis::exec::parseNumber(light->data) : std::nullopt;
        if (!lux && attemptsLeft > 0) {  // just started: the readings may still be on their way
          kernel.after(std::chrono::milliseconds(200),
                       [&, a, id, attemptsLeft] { shoot(a, id, attemptsLeft - 1); });
          return;
        }
        if (world == 0) return failed("no world " + worldName + " to see");
        if (!lux) return failed("no light reading at '" + region + "'");
        const auto worldFile = kernel.get(world, "physics.world");
        const auto colour = worldFile ? colourOf(worldFile->data, region) : std::nullopt;
        const cv::Mat photo = peis::devices::takePhoto(
            colour.value_or(std::array<int, 3>{128, 128, 128}), *lux, settings, ++shots);
        const double brightness = peis::devices::measureBrightness(photo);
        peis::WriteOptions png;
        png.mimetype = "image/png";
        png.encoding = peis::Encoding::Binary;
        if (light) png.ts_user = light->ts_user;
        kernel.set("photo", peis::devices::encodePng(photo), png);
        char text[32];
        std::snprintf(text, sizeof text, "%.1f", brightness);
        kernel.set("photo.brightness", text);
        std::cerr << "photo-camera: photo of " << region << " at " << *lux << " lux: brightness "
                  << text << std::endl;
        if (brightness < minBrightness)
          return failed(std::string("too dark (brightness ") + text + " < " +
                        std::to_string(static_cast<int>(minBrightness)) + ")");
        server->publish({peis::exec::ExecState::Success, id, a.toString(), ""});
      };
  server = std::make_unique<peis::exec::ExecServer>(
      kernel,
      [](const peis::exec::Action& a) -> std::optional<std::string> {
        if (a.name != "Photo" || a.args.size() != 1) return "the photo camera does Photo(<region>)";
        return std::nullopt;
      },
      [&](const peis::exec::Action& a, std::uint64_t id) { shoot(a, id, 10); });
  peis::exec::whenPeerKnown(kernel, worldName, [&](peis::PeisId id) {
    world = id;
    kernel.subscribe(peis::Pattern("physics.light.*", id));
    kernel.subscribe(peis::Pattern("physics.world", id));
  });
  component.start();
  kernel.run();
  return 0;
}
