// Reading tracking targets (targets.h).
#include "tracking/targets.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>

#include "common/yaml_reader.h"
#include "peis/error.h"

namespace peis::tracking {

double hueOf(int r, int g, int b) {
  const double max = std::max({r, g, b}), min = std::min({r, g, b});
  if (max - min < 1e-9) return 0;
  double degrees;
  if (max == r)
    degrees = 60 * std::fmod((g - b) / (max - min), 6.0);
  else if (max == g)
    degrees = 60 * ((b - r) / (max - min) + 2);
  else
    degrees = 60 * ((r - g) / (max - min) + 4);
  if (degrees < 0) degrees += 360;
  return degrees / 2;
}

namespace {

double colourHue(const components::YamlReader& r, const YAML::Node& colour) {
  const auto rgb = r.numbers(colour, 3, "colour [r, g, b]");
  for (double c : rgb)
    if (c < 0 || c > 255) r.fail(colour, "colour values must be 0..255");
  const double max = std::max({rgb[0], rgb[1], rgb[2]}), min = std::min({rgb[0], rgb[1], rgb[2]});
  if (max < 60 || (max - min) / max < 0.5)
    r.fail(colour, "a hat colour must be saturated and bright (saturation >= 0.5, value >= 60)");
  return hueOf(static_cast<int>(rgb[0]), static_cast<int>(rgb[1]), static_cast<int>(rgb[2]));
}

}  // namespace

std::vector<Target> parseTargets(std::string_view text, const std::string& origin) {
  const components::YamlReader r(origin);
  const YAML::Node root = r.parse(text);
  if (!root.IsMap())
    r.fail(root, "a targets file must be a mapping with 'targets' (or a world file)");
  std::vector<Target> targets;
  if (root["targets"]) {
    r.onlyKeys(root, {"targets"}, "a targets file");
    for (const auto& item : r.list(root["targets"], "targets")) {
      r.onlyKeys(item, {"name", "colour", "height", "radius"}, "a target");
      Target t;
      t.name = r.name(r.required(item, "name", "a target"), "target name");
      t.hue = colourHue(r, r.required(item, "colour", "a target"));
      t.height = r.numberIn(r.required(item, "height", "a target"), 0, 5, "target height");
      t.radius = r.numberIn(item, "radius", t.radius, 0.01, 1, "target radius");
      targets.push_back(t);
    }
  } else if (root["robots"]) {
    // A world file: each robot with a hat, seen at the middle of the hat's
    // thickness (its top and its rim both show in the images).
    for (const auto& robot : r.list(root["robots"], "robots")) {
      if (!robot.IsMap() || !robot["hat"]) continue;
      const YAML::Node hat = robot["hat"];
      Target t;
      t.name = r.name(r.required(robot, "name", "a robot"), "robot name");
      t.hue = hat["colour"] ? colourHue(r, hat["colour"]) : hueOf(220, 30, 30);
      t.height = r.number(robot, "height", 0.5, "robot height") +
                 r.number(hat, "thickness", 0.02, "hat thickness") / 2;
      t.radius = r.number(hat, "radius", 0.1, "hat radius");
      targets.push_back(t);
    }
  } else {
    r.fail(root, "a targets file needs 'targets' (or a world file's 'robots')");
  }
  if (targets.empty()) r.fail(root, "no targets to track");
  for (std::size_t i = 0; i < targets.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (targets[i].name == targets[j].name)
        throw Error(ErrorCode::InvalidConfig,
                    origin + ": target '" + targets[i].name + "' is declared twice");
  return targets;
}

std::vector<Target> loadTargets(const std::string& path) {
  return parseTargets(components::readTextFile(path, "targets file"), path);
}

}  // namespace peis::tracking
