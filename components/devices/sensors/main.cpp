// peis-sim-sensors: feeds the simulated home's light and objects to the
// sensors of tiny nodes on the host port (the plant's light sensor, the
// parcel's weight sensor) through their TINY_SENSOR_FILE. The actuators go
// the other way without it: peis-sim-world --bind makes the world follow a
// tiny node's reported state (LampLevel, BlindPosition) through the bridge.
// Its `fault.freeze` input (on / off) simulates stuck sensors: while on, the
// files keep the last readings. docs/components/sim-sensors.md.
#include <peis/component.h>

#include <iostream>
#include <map>

#include "execution/exec_server.h"
#include "execution/program_options.h"
#include "sensor_file.h"
#include "sensors_descriptor.h"

namespace {

const char* kUsage = R"usage(Usage: peis-sim-sensors [OPTIONS] [--peis-* flags]

Writes tiny nodes' sensor files (TINY_SENSOR_FILE of the host port) from the
simulated world's physics channel.

Options:
  --world NAME           the world PEIS (default: world)
  --light THING=FILE     light level at THING (physics.light.THING) into FILE
  --weight OBJECT=FILE   weight of OBJECT (physics.object.OBJECT) into FILE
  --lux-per-level L      lux per light level 0..1000 (default 2: level 700 = 1400 lux)
  --help                 this text

Tuples: fault.freeze (in, local or remote): `on` holds every file at its last
readings (stuck sensors), `off` writes the current readings again.
)usage";

}  // namespace

int main(int argc, char** argv) {
  if (peis::exec::printedHelp(argc, argv, kUsage)) return 0;
  peis::Kernel kernel(argc, argv);
  std::string worldName = "world";
  double luxPerLevel = 2;
  std::map<std::string, std::string> lights, weights;  // source -> file
  const int code = peis::exec::parseProgramOptions(
      argc, argv, "peis-sim-sensors", kUsage,
      [&](const std::string& name, const std::string& value) {
        const auto eq = value.find('=');
        const auto number = peis::exec::parseNumber(value);
        if (name == "--world")
          worldName = value;
        else if ((name == "--light" || name == "--weight") && eq != std::string::npos && eq > 0 &&
                 eq + 1 < value.size())
          (name == "--light" ? lights : weights)[value.substr(0, eq)] = value.substr(eq + 1);
        else if (name == "--lux-per-level" && number && *number > 0)
          luxPerLevel = *number;
        else
          return false;
        return true;
      });
  if (code >= 0) return code;
  peis::Component component(kernel, "sim-sensors",
                            peis::Descriptor::fromYaml(kSensorsDescriptor, "sensors.yaml"));
  std::map<std::string, peis::devices::SensorValues> files;
  bool frozen = false;  // kernel thread only
  auto write = [&](const std::string& file) {
    if (frozen) return;  // a stuck sensor: the node keeps reading the old value
    if (!peis::devices::writeAtomically(file, peis::devices::formatSensorFile(files[file])))
      std::cerr << "peis-sim-sensors: cannot write " << file << std::endl;
  };
  kernel.onChange(peis::Pattern::exact(kernel.id(), "fault.freeze"), [&](const peis::Tuple& t) {
    const bool freeze = t.data == "on";
    if (freeze == frozen) return;
    frozen = freeze;
    std::cerr << "peis-sim-sensors: readings " << (frozen ? "frozen" : "moving again") << std::endl;
    if (!frozen) {
      for (const auto& [file, values] : files) write(file);
    }
  });
  peis::exec::whenPeerKnown(kernel, worldName, [&](peis::PeisId world) {
    for (const auto& [thing, file] : lights) {
      kernel.subscribe(peis::Pattern("physics.light." + thing, world));
      kernel.onChange(peis::Pattern("physics.light." + thing, world),
                      [&, file = file](const peis::Tuple& t) {
                        const auto lux = peis::exec::parseNumber(t.data);
                        if (!lux) return;
                        files[file].light = peis::devices::lightLevel(*lux, luxPerLevel);
                        write(file);
                      });
    }
    for (const auto& [object, file] : weights) {
      kernel.subscribe(peis::Pattern("physics.object." + object, world));
      kernel.onChange(peis::Pattern("physics.object." + object, world),
                      [&, file = file](const peis::Tuple& t) {
                        const auto grams = peis::devices::weightGrams(t.data);
                        if (!grams) return;
                        files[file].weight = *grams;
                        write(file);
                      });
    }
  });
  component.start();
  kernel.run();
  return 0;
}
