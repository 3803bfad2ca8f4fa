// The host-side adapter between the simulated home and the tiny nodes'
// sensors (pure parts). A tiny device program on the host port reads its
// sensors through the HAL (tiny_port_sensor); the host port takes the values
// from a small text file (TINY_SENSOR_FILE: "light N" and "weight N" lines).
// peis-sim-sensors writes that file from the world's physics channel: the
// light level from physics.light.<thing> (lux), the weight in grams from
// physics.object.<name> ("X Y THETA WEIGHT_KG"). No simulator knowledge goes
// into the tiny kernel or the device programs.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace peis::devices {

struct SensorValues {
  std::optional<long> light;   // level 0..1000
  std::optional<long> weight;  // grams
};

// The file's text: "light N\n" and/or "weight N\n".
std::string formatSensorFile(const SensorValues& values);
// Lux -> the light sensor's level 0..1000 (luxPerLevel lux per level).
long lightLevel(double lux, double luxPerLevel);
// physics.object.<name> = "X Y THETA WEIGHT_KG" -> grams, or nothing if malformed.
std::optional<long> weightGrams(std::string_view objectLine);
// Writes `text` to `path` atomically (a temporary file renamed over it).
bool writeAtomically(const std::string& path, const std::string& text);

}  // namespace peis::devices
