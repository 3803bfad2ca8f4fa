// Targets: the robots the tracker follows, each known by the colour of its
// hat and the height of the hat's top. Read from a targets file
// (`targets:` list) or from a world file (its `robots:` with their hats),
// so the home's own description can serve (docs/components/tracking.md).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace peis::tracking {

struct Target {
  std::string name;
  double hue = 0;       // OpenCV hue, 0..180 (degrees / 2)
  double height = 0.5;  // metres: the top of the hat above the floor
  double radius = 0.1;  // metres: the hat's radius
};

// Throws Error(InvalidConfig) "file:line: problem".
std::vector<Target> parseTargets(std::string_view text, const std::string& origin);
std::vector<Target> loadTargets(const std::string& path);
// OpenCV hue (0..180) of an RGB colour.
double hueOf(int r, int g, int b);

}  // namespace peis::tracking
