// The tiny nodes' sensor file (see sensor_file.h).
#include "sensor_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "execution/exec_server.h"

namespace peis::devices {

std::string formatSensorFile(const SensorValues& values) {
  std::string out;
  if (values.light) out += "light " + std::to_string(*values.light) + "\n";
  if (values.weight) out += "weight " + std::to_string(*values.weight) + "\n";
  return out;
}

long lightLevel(double lux, double luxPerLevel) {
  if (!(luxPerLevel > 0) || !std::isfinite(lux)) return 0;
  return std::clamp(std::lround(lux / luxPerLevel), 0L, 1000L);
}

std::optional<long> weightGrams(std::string_view objectLine) {
  const auto fields = exec::parseNumbers(objectLine);
  if (!fields || fields->size() != 4 || (*fields)[3] < 0) return std::nullopt;
  return std::lround((*fields)[3] * 1000.0);
}

bool writeAtomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::trunc);
    if (!(out << text)) return false;
  }
  return std::rename(temporary.c_str(), path.c_str()) == 0;
}

}  // namespace peis::devices
