// The physics.scene text (scene.h).
#include "sim/world/scene.h"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace peis::sim {

Scene sceneOf(const Simulation& simulation) {
  const World& world = simulation.world();
  Scene scene;
  scene.time = simulation.time();
  const LightState& light = simulation.light();
  scene.daylightLux = light.daylightLux;
  for (std::size_t i = 0; i < world.windows.size(); ++i)
    if (!world.windows[i].blind.empty())
      scene.blinds.emplace_back(world.windows[i].blind, light.blindTilt[i]);
  for (std::size_t i = 0; i < world.lamps.size(); ++i)
    scene.lamps.emplace_back(world.lamps[i].name, light.lampLevel[i]);
  for (std::size_t i = 0; i < world.robots.size(); ++i)
    scene.robots.push_back({world.robots[i].name, simulation.robot(i).pose});
  for (std::size_t i = 0; i < world.objects.size(); ++i)
    scene.objects.push_back({world.objects[i].name, simulation.objectPose(i)});
  for (std::size_t i = 0; i < world.people.size(); ++i)
    scene.people.emplace_back(world.people[i].name, simulation.personState(i));
  return scene;
}

std::string formatScene(const Scene& scene) {
  std::string out;
  char line[256];
  const auto add = [&](int n) { out.append(line, static_cast<std::size_t>(std::min(n, 255))); };
  add(std::snprintf(line, sizeof line, "time %.4f\ndaylight %.1f\n", scene.time,
                    scene.daylightLux));
  for (const auto& [name, tilt] : scene.blinds)
    add(std::snprintf(line, sizeof line, "blind %s %.1f\n", name.c_str(), tilt));
  for (const auto& [name, level] : scene.lamps)
    add(std::snprintf(line, sizeof line, "lamp %s %.1f\n", name.c_str(), level));
  for (const auto& r : scene.robots)
    add(std::snprintf(line, sizeof line, "robot %s %.4f %.4f %.5f\n", r.name.c_str(), r.pose.x,
                      r.pose.y, r.pose.theta));
  for (const auto& o : scene.objects)
    add(std::snprintf(line, sizeof line, "object %s %.4f %.4f %.5f\n", o.name.c_str(), o.pose.x,
                      o.pose.y, o.pose.theta));
  for (const auto& [name, state] : scene.people)
    add(std::snprintf(line, sizeof line, "person %s %s\n", name.c_str(), state.c_str()));
  return out;
}

Scene parseScene(std::string_view text) {
  Scene scene;
  std::istringstream in{std::string(text)};
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty()) continue;
    std::istringstream fields(line);
    std::string kind, name;
    fields >> kind;
    const auto bad = [&]() {
      return std::invalid_argument("scene line " + std::to_string(number) + " is malformed: '" +
                                   line.substr(0, 80) + "'");
    };
    const auto finite = [&](double v) {
      if (!std::isfinite(v)) throw bad();
      return v;
    };
    const auto pose = [&]() {
      Pose2 p;
      if (!(fields >> name >> p.x >> p.y >> p.theta)) throw bad();
      finite(p.x), finite(p.y), finite(p.theta);
      return Scene::Named{name, p};
    };
    double value = 0;
    if (kind == "time") {
      if (!(fields >> value)) throw bad();
      scene.time = finite(value);
    } else if (kind == "daylight") {
      if (!(fields >> value)) throw bad();
      scene.daylightLux = finite(value);
    } else if (kind == "blind" || kind == "lamp") {
      if (!(fields >> name >> value)) throw bad();
      (kind == "blind" ? scene.blinds : scene.lamps).emplace_back(name, finite(value));
    } else if (kind == "robot") {
      scene.robots.push_back(pose());
    } else if (kind == "object") {
      scene.objects.push_back(pose());
    } else if (kind == "person") {
      std::string state;
      if (!(fields >> name >> state)) throw bad();
      scene.people.emplace_back(name, state);
    }
  }
  return scene;
}

LightState lightStateOf(const World& world, const Scene& scene) {
  LightState light = initialLightState(world);
  light.daylightLux = scene.daylightLux;
  for (std::size_t i = 0; i < world.windows.size(); ++i)
    for (const auto& [name, tilt] : scene.blinds)
      if (!world.windows[i].blind.empty() && name == world.windows[i].blind)
        light.blindTilt[i] = tilt;
  for (std::size_t i = 0; i < world.lamps.size(); ++i)
    for (const auto& [name, level] : scene.lamps)
      if (name == world.lamps[i].name) light.lampLevel[i] = level;
  return light;
}

}  // namespace peis::sim
