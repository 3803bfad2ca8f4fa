// Test helper: small world files for the simulated-home tests, and the path
// of the reference PEIS-Home.
#pragma once

#include <string>

namespace peis::test {

inline std::string peisHomePath() {
  return std::string(PEIS_SOURCE_DIR) + "/components/sim/homes/peis-home.yaml";
}

// A 4 m x 3 m room with walls around it, a 1 m box at (2, 1.5)..., one robot.
// `extra` is appended (more top-level keys).
inline std::string boxWorld(const std::string& robots = "", const std::string& extra = "") {
  return "name: box-world\n"
         "size: [4, 3]\n"
         "resolution: 0.05\n"
         "daylight_lux: 1000\n"
         "ambient_lux: 0\n"
         "rooms:\n"
         "  - {name: room, polygon: [[0, 0], [4, 0], [4, 3], [0, 3]]}\n"
         "walls:\n"
         "  - {points: [[0, 0], [4, 0], [4, 3], [0, 3], [0, 0]], thickness: 0.1}\n"
         "furniture:\n"
         "  - {name: box, box: {centre: [3.0, 1.5], size: [1.0, 1.0]}, height: 0.5}\n" +
         (robots.empty() ? std::string() : "robots:\n" + robots) + extra;
}

}  // namespace peis::test
