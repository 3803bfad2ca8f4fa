// Reading a world file (world.h): YAML with every error naming file:line.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <map>
#include <set>

#include "common/yaml_reader.h"
#include "peis/error.h"
#include "sim/world/world.h"

namespace peis::sim {
namespace {

constexpr double kDegree = M_PI / 180.0;

class WorldReader {
 public:
  explicit WorldReader(const std::string& origin) : r_(origin) {}

  World read(std::string_view text) {
    const YAML::Node root = r_.parse(text);
    if (!root.IsMap()) r_.fail(root, "a world file must be a mapping");
    r_.onlyKeys(
        root,
        {"name", "size", "resolution", "daylight_lux", "ambient_lux", "rooms", "walls", "windows",
         "furniture", "lamps", "objects", "people", "robots", "cameras", "places"},
        "the world file");
    World w;
    w.origin = r_.origin();
    w.sourceText = std::string(text);
    w.name = r_.name(r_.required(root, "name", "the world file"), "world name");
    const auto size = r_.numbers(r_.required(root, "size", "the world file"), 2, "size");
    if (size[0] <= 0 || size[1] <= 0 || size[0] > 1000 || size[1] > 1000)
      r_.fail(root["size"], "size must be two lengths in (0, 1000] metres");
    w.size = {size[0], size[1]};
    w.resolution = r_.numberIn(root, "resolution", 0.05, 0.005, 1.0, "resolution");
    if (w.size.x / w.resolution * w.size.y / w.resolution > 64e6)
      r_.fail(root["resolution"], "the map would have more than 64 million cells");
    w.daylightLux = r_.numberIn(root, "daylight_lux", w.daylightLux, 0, 200000, "daylight_lux");
    w.ambientLux = r_.numberIn(root, "ambient_lux", w.ambientLux, 0, 100000, "ambient_lux");
    size_ = w.size;
    for (const auto& n : r_.list(root["rooms"], "rooms")) w.rooms.push_back(room(n));
    for (const auto& n : r_.list(root["walls"], "walls")) w.walls.push_back(wall(n));
    for (const auto& n : r_.list(root["windows"], "windows")) w.windows.push_back(window(n));
    for (const auto& n : r_.list(root["furniture"], "furniture"))
      w.furniture.push_back(furniture(n));
    for (const auto& n : r_.list(root["lamps"], "lamps")) w.lamps.push_back(lamp(n));
    for (const auto& n : r_.list(root["objects"], "objects")) w.objects.push_back(object(n));
    for (const auto& n : r_.list(root["people"], "people")) w.people.push_back(person(n));
    for (const auto& n : r_.list(root["robots"], "robots")) w.robots.push_back(robot(n));
    for (const auto& n : r_.list(root["cameras"], "cameras")) w.cameras.push_back(camera(n));
    if (const YAML::Node places = root["places"]) {
      if (!places.IsMap()) r_.fail(places, "places must be a mapping of name: [x, y, theta_deg]");
      for (const auto& item : places) {
        Place p;
        p.name = r_.name(item.first, "place name");
        p.pose = pose(item.second, "place " + p.name);
        unique("place", p.name, item.first);
        w.places.push_back(p);
      }
    }
    checkPlacement(w, root);
    return w;
  }

 private:
  Colour colour(const YAML::Node& map, Colour fallback) {
    const YAML::Node node = map["colour"];
    if (!node) return fallback;
    const auto v = r_.numbers(node, 3, "colour [r, g, b]");
    for (double c : v)
      if (c < 0 || c > 255 || c != std::floor(c)) r_.fail(node, "colour values must be 0..255");
    return {static_cast<std::uint8_t>(v[0]), static_cast<std::uint8_t>(v[1]),
            static_cast<std::uint8_t>(v[2])};
  }

  Vec2 point(const YAML::Node& node, const std::string& what, bool inMap = true) {
    const auto v = r_.numbers(node, 2, what + " [x, y]");
    const Vec2 p{v[0], v[1]};
    if (inMap && !(p.x >= 0 && p.y >= 0 && p.x <= size_.x && p.y <= size_.y))
      r_.fail(node, what + " (" + fmt(p.x) + ", " + fmt(p.y) + ") is outside the map [0, " +
                        fmt(size_.x) + "] x [0, " + fmt(size_.y) + "]");
    return p;
  }

  Pose2 pose(const YAML::Node& node, const std::string& what) {
    const auto v = r_.numbers(node, 3, what + " [x, y, theta_deg]");
    if (!(v[0] >= 0 && v[1] >= 0 && v[0] <= size_.x && v[1] <= size_.y))
      r_.fail(node, what + " (" + fmt(v[0]) + ", " + fmt(v[1]) + ") is outside the map [0, " +
                        fmt(size_.x) + "] x [0, " + fmt(size_.y) + "]");
    return {v[0], v[1], normalizeAngle(v[2] * kDegree)};
  }

  Polygon polygon(const YAML::Node& node, const std::string& what) {
    if (!node.IsSequence() || node.size() < 3)
      r_.fail(node, what + " polygon must be a list of at least 3 points");
    Polygon p;
    for (const auto& item : node) p.push_back(point(item, what + " point"));
    if (std::abs(signedArea(p)) < 1e-9) r_.fail(node, what + " polygon has no area");
    return p;
  }

  void unique(const std::string& kind, const std::string& name, const YAML::Node& at) {
    if (!names_[kind].insert(name).second) r_.fail(at, kind + " '" + name + "' is declared twice");
  }
  // Things whose light the world publishes as physics.light.<name> share one namespace.
  void uniqueThing(const std::string& name, const YAML::Node& at) {
    if (!names_["thing"].insert(name).second)
      r_.fail(at,
              "the name '" + name + "' is used twice among furniture, lamps, objects and people");
  }

  Room room(const YAML::Node& n) {
    r_.onlyKeys(n, {"name", "polygon", "colour"}, "a room");
    Room room;
    room.name = r_.name(r_.required(n, "name", "a room"), "room name");
    unique("room", room.name, n["name"]);
    room.polygon = polygon(r_.required(n, "polygon", "a room"), "room " + room.name);
    room.colour = colour(n, room.colour);
    return room;
  }

  Wall wall(const YAML::Node& n) {
    r_.onlyKeys(n, {"points", "thickness", "height", "colour"}, "a wall");
    Wall wall;
    const YAML::Node points = r_.required(n, "points", "a wall");
    if (!points.IsSequence() || points.size() < 2)
      r_.fail(points, "wall points must be a list of at least 2 points");
    for (const auto& p : points) wall.points.push_back(point(p, "wall point"));
    wall.thickness = r_.numberIn(n, "thickness", wall.thickness, 0.01, 2, "wall thickness");
    wall.height = r_.numberIn(n, "height", wall.height, 0.1, 10, "wall height");
    wall.colour = colour(n, wall.colour);
    return wall;
  }

  Window window(const YAML::Node& n) {
    r_.onlyKeys(n, {"name", "from", "to", "sill", "top", "blind"}, "a window");
    Window w;
    w.name = r_.name(r_.required(n, "name", "a window"), "window name");
    unique("window", w.name, n["name"]);
    w.from = point(r_.required(n, "from", "a window"), "window from");
    w.to = point(r_.required(n, "to", "a window"), "window to");
    if ((w.to - w.from).norm() < 0.05) r_.fail(n, "window '" + w.name + "' is shorter than 5 cm");
    w.sill = r_.numberIn(n, "sill", w.sill, 0, 10, "window sill");
    w.top = r_.numberIn(n, "top", w.top, 0, 10, "window top");
    if (w.top <= w.sill) r_.fail(n, "window '" + w.name + "': top must be above sill");
    if (const YAML::Node blind = n["blind"]) {
      r_.onlyKeys(blind, {"name", "tilt"}, "a blind");
      w.blind = r_.name(r_.required(blind, "name", "a blind"), "blind name");
      unique("blind", w.blind, blind["name"]);
      w.tilt = r_.numberIn(blind, "tilt", 100, 0, 100, "blind tilt");
    }
    return w;
  }

  Furniture furniture(const YAML::Node& n) {
    r_.onlyKeys(n, {"name", "polygon", "box", "height", "colour"}, "a piece of furniture");
    Furniture f;
    f.name = r_.name(r_.required(n, "name", "a piece of furniture"), "furniture name");
    uniqueThing(f.name, n["name"]);
    if (n["polygon"] && n["box"]) r_.fail(n["box"], "furniture has a polygon or a box, not both");
    if (const YAML::Node b = n["box"]) {
      r_.onlyKeys(b, {"centre", "size", "theta_deg"}, "a box");
      const Vec2 centre = point(r_.required(b, "centre", "a box"), "box centre");
      const auto size = r_.numbers(r_.required(b, "size", "a box"), 2, "box size");
      if (size[0] <= 0 || size[1] <= 0) r_.fail(b["size"], "box size must be positive");
      f.polygon =
          box(centre, {size[0], size[1]}, r_.number(b, "theta_deg", 0, "box theta_deg") * kDegree);
      for (const Vec2 corner : f.polygon)
        if (!(corner.x >= 0 && corner.y >= 0 && corner.x <= size_.x && corner.y <= size_.y))
          r_.fail(b, "furniture '" + f.name + "' reaches outside the map");
    } else {
      f.polygon = polygon(r_.required(n, "polygon", "a piece of furniture (or box)"), f.name);
    }
    f.height = r_.numberIn(n, "height", f.height, 0.01, 5, "furniture height");
    f.colour = colour(n, f.colour);
    return f;
  }

  Lamp lamp(const YAML::Node& n) {
    r_.onlyKeys(n, {"name", "position", "height", "max_cd", "level", "colour"}, "a lamp");
    Lamp l;
    l.name = r_.name(r_.required(n, "name", "a lamp"), "lamp name");
    uniqueThing(l.name, n["name"]);
    l.position = point(r_.required(n, "position", "a lamp"), "lamp position");
    l.height = r_.numberIn(n, "height", l.height, 0.1, 10, "lamp height");
    l.maxCandela = r_.numberIn(n, "max_cd", l.maxCandela, 0, 1e6, "lamp max_cd");
    l.level = r_.numberIn(n, "level", l.level, 0, 100, "lamp level");
    l.colour = colour(n, l.colour);
    return l;
  }

  Object object(const YAML::Node& n) {
    r_.onlyKeys(n,
                {"name", "position", "theta_deg", "radius", "size", "height", "weight_kg",
                 "movable", "colour"},
                "an object");
    Object o;
    o.name = r_.name(r_.required(n, "name", "an object"), "object name");
    uniqueThing(o.name, n["name"]);
    const Vec2 p = point(r_.required(n, "position", "an object"), "object position");
    o.pose = {p.x, p.y, r_.number(n, "theta_deg", 0, "object theta_deg") * kDegree};
    if (n["radius"] && n["size"]) r_.fail(n["size"], "an object has a radius or a size, not both");
    if (n["size"]) {
      const auto size = r_.numbers(n["size"], 2, "object size");
      if (size[0] <= 0 || size[1] <= 0) r_.fail(n["size"], "object size must be positive");
      o.size = {size[0], size[1]};
    } else {
      o.radius = r_.numberIn(n, "radius", 0.15, 0.01, 5, "object radius");
    }
    o.height = r_.numberIn(n, "height", o.height, 0.01, 5, "object height");
    o.weightKg = r_.numberIn(n, "weight_kg", o.weightKg, 0, 10000, "object weight_kg");
    o.movable = r_.flag(n, "movable", false, "object movable");
    o.colour = colour(n, o.colour);
    return o;
  }

  Person person(const YAML::Node& n) {
    r_.onlyKeys(n, {"name", "position", "theta_deg", "state", "hearing_m", "colour"}, "a person");
    Person p;
    p.name = r_.name(r_.required(n, "name", "a person"), "person name");
    uniqueThing(p.name, n["name"]);
    const Vec2 at = point(r_.required(n, "position", "a person"), "person position");
    p.pose = {at.x, at.y, r_.number(n, "theta_deg", 0, "person theta_deg") * kDegree};
    if (n["state"]) {
      p.state = r_.text(n["state"], "person state");
      if (p.state != "asleep" && p.state != "awake")
        r_.fail(n["state"], "person state must be asleep or awake, not '" + p.state + "'");
    }
    p.hearingM = r_.numberIn(n, "hearing_m", p.hearingM, 0, 100, "person hearing_m");
    p.colour = colour(n, p.colour);
    return p;
  }

  Robot robot(const YAML::Node& n) {
    r_.onlyKeys(n,
                {"name", "driver", "driver_id", "pose", "radius", "height", "max_speed",
                 "max_turn_deg_s", "max_accel", "max_turn_accel_deg_s2", "push_kg", "cmd_timeout",
                 "battery_hours", "odometry_noise", "sonar", "hat", "colour"},
                "a robot");
    Robot robot;
    robot.name = r_.name(r_.required(n, "name", "a robot"), "robot name");
    unique("robot", robot.name, n["name"]);
    robot.driver = n["driver"] ? r_.name(n["driver"], "robot driver") : robot.name + "-base";
    if (robot.driver.size() > 64)
      r_.fail(n["name"], "the driver name '" + robot.driver + "' is too long");
    unique("driver", robot.driver, n["name"]);
    if (n["driver_id"])
      robot.driverId = static_cast<int>(r_.numberIn(n["driver_id"], 1, 2147483647.0, "driver_id"));
    robot.start = pose(r_.required(n, "pose", "a robot"), "robot " + robot.name + " pose");
    robot.radius = r_.numberIn(n, "radius", robot.radius, 0.02, 2, "robot radius");
    robot.height = r_.numberIn(n, "height", robot.height, 0.02, 3, "robot height");
    robot.maxSpeed = r_.numberIn(n, "max_speed", robot.maxSpeed, 0.01, 10, "robot max_speed");
    robot.maxTurn =
        r_.numberIn(n, "max_turn_deg_s", robot.maxTurn / kDegree, 1, 1440, "robot max_turn_deg_s") *
        kDegree;
    robot.maxAccel = r_.numberIn(n, "max_accel", robot.maxAccel, 0.01, 100, "robot max_accel");
    robot.maxTurnAccel = r_.numberIn(n, "max_turn_accel_deg_s2", robot.maxTurnAccel / kDegree, 1,
                                     100000, "robot max_turn_accel_deg_s2") *
                         kDegree;
    robot.pushKg = r_.numberIn(n, "push_kg", robot.pushKg, 0, 10000, "robot push_kg");
    robot.cmdTimeout = r_.numberIn(n, "cmd_timeout", robot.cmdTimeout, 0.01, 3600, "cmd_timeout");
    robot.batteryHours =
        r_.numberIn(n, "battery_hours", robot.batteryHours, 0.01, 10000, "battery_hours");
    if (const YAML::Node noise = n["odometry_noise"]) {
      r_.onlyKeys(noise, {"trans", "rot", "drift"}, "odometry_noise");
      robot.odometryNoise.trans =
          r_.numberIn(noise, "trans", robot.odometryNoise.trans, 0, 1, "odometry_noise trans");
      robot.odometryNoise.rot =
          r_.numberIn(noise, "rot", robot.odometryNoise.rot, 0, 1, "odometry_noise rot");
      robot.odometryNoise.drift = r_.numberIn(noise, "drift", robot.odometryNoise.drift / kDegree,
                                              0, 90, "odometry_noise drift (deg/m)") *
                                  kDegree;
    }
    robot.sonarAngles.clear();
    for (double a : {-90.0, -50.0, -30.0, -10.0, 10.0, 30.0, 50.0, 90.0})
      robot.sonarAngles.push_back(a * kDegree);
    if (const YAML::Node sonar = n["sonar"]) {
      r_.onlyKeys(sonar, {"angles_deg", "max_range"}, "sonar");
      if (sonar["angles_deg"]) {
        robot.sonarAngles.clear();
        for (const auto& a : r_.list(sonar["angles_deg"], "sonar angles_deg"))
          robot.sonarAngles.push_back(r_.numberIn(a, -360, 360, "sonar angle") * kDegree);
        if (robot.sonarAngles.size() > 64) r_.fail(sonar["angles_deg"], "at most 64 sonars");
      }
      robot.sonarMaxRange =
          r_.numberIn(sonar, "max_range", robot.sonarMaxRange, 0.1, 100, "sonar max_range");
    }
    if (const YAML::Node hat = n["hat"]) {
      r_.onlyKeys(hat, {"colour", "radius", "thickness"}, "a hat");
      robot.hat.colour = colour(hat, robot.hat.colour);
      robot.hat.radius = r_.numberIn(hat, "radius", robot.hat.radius, 0.01, 1, "hat radius");
      robot.hat.thickness =
          r_.numberIn(hat, "thickness", robot.hat.thickness, 0, 0.5, "hat thickness");
      if (robot.hat.radius > robot.radius) r_.fail(hat, "the hat is wider than the robot");
    }
    robot.colour = colour(n, robot.colour);
    return robot;
  }

  camera::CameraSpec camera(const YAML::Node& n) {
    camera::CameraSpec spec = camera::cameraFromYaml(r_, n);
    unique("camera", spec.calibration.name, n["name"]);
    const auto& c = spec.calibration;
    if (!c.intersectHeight(c.cx, c.cy, 0))
      r_.fail(n, "camera '" + c.name +
                     "' does not look at the floor (its centre ray never meets z = 0)");
    return spec;
  }

  // Robots, places, people and objects must stand on free floor.
  void checkPlacement(const World& w, const YAML::Node& root) {
    const auto obstacles = namedObstacles(w);
    const auto clash = [&](Vec2 p, double radius) -> std::string {
      for (const auto& [name, poly] : obstacles)
        if (insidePolygon(poly, p) || distanceToBoundary(poly, p) < radius) return name;
      return {};
    };
    const YAML::Node robots = root["robots"];
    for (std::size_t i = 0; i < w.robots.size(); ++i) {
      const Robot& robot = w.robots[i];
      if (auto what = clash(robot.start.position(), robot.radius); !what.empty())
        r_.fail(robots[i]["pose"], "robot '" + robot.name + "' starts inside " + what);
      for (std::size_t j = 0; j < i; ++j)
        if ((w.robots[j].start.position() - robot.start.position()).norm() <
            robot.radius + w.robots[j].radius)
          r_.fail(robots[i]["pose"],
                  "robot '" + robot.name + "' starts on robot '" + w.robots[j].name + "'");
    }
    for (const Place& place : w.places)
      if (auto what = clash(place.pose.position(), 0); !what.empty())
        r_.fail(root["places"][place.name], "place '" + place.name + "' is inside " + what);
    const YAML::Node objects = root["objects"];
    for (std::size_t i = 0; i < w.objects.size(); ++i)
      if (w.objects[i].movable)
        if (auto what = clash(w.objects[i].pose.position(), w.objects[i].collisionRadius());
            !what.empty())
          r_.fail(objects[i]["position"],
                  "movable object '" + w.objects[i].name + "' is inside " + what);
  }

  static std::vector<std::pair<std::string, Polygon>> namedObstacles(const World& w) {
    std::vector<std::pair<std::string, Polygon>> result;
    for (const Wall& wall : w.walls)
      for (std::size_t i = 1; i < wall.points.size(); ++i)
        result.emplace_back("a wall",
                            thickSegment(wall.points[i - 1], wall.points[i], wall.thickness));
    for (const Furniture& f : w.furniture)
      result.emplace_back("furniture '" + f.name + "'", f.polygon);
    return result;
  }

  static std::string fmt(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%g", v);
    return buffer;
  }

  components::YamlReader r_;
  Vec2 size_;
  std::map<std::string, std::set<std::string>> names_;
};

}  // namespace

double Object::collisionRadius() const {
  return radius > 0 ? radius : std::hypot(size.x, size.y) / 2;
}

Polygon Object::footprint() const {
  if (radius <= 0) return box(pose.position(), size, pose.theta);
  Polygon circle;
  for (int i = 0; i < 24; ++i) {
    const double a = 2 * M_PI * i / 24;
    circle.push_back({pose.x + radius * std::cos(a), pose.y + radius * std::sin(a)});
  }
  return circle;
}

const Robot* World::robot(std::string_view name) const {
  for (const auto& r : robots)
    if (r.name == name) return &r;
  return nullptr;
}

const Place* World::place(std::string_view name) const {
  for (const auto& p : places)
    if (p.name == name) return &p;
  return nullptr;
}

const camera::CameraSpec* World::camera(std::string_view name) const {
  for (const auto& c : cameras)
    if (c.calibration.name == name) return &c;
  return nullptr;
}

const Room* World::roomAt(Vec2 p) const {
  for (const auto& room : rooms)
    if (insidePolygon(room.polygon, p)) return &room;
  return nullptr;
}

std::vector<Polygon> World::obstacles() const {
  std::vector<Polygon> result;
  for (const Wall& wall : walls)
    for (std::size_t i = 1; i < wall.points.size(); ++i)
      result.push_back(thickSegment(wall.points[i - 1], wall.points[i], wall.thickness));
  for (const Furniture& f : furniture) result.push_back(f.polygon);
  for (const Object& o : objects)
    if (!o.movable) result.push_back(o.footprint());
  // A floor lamp stands on a base of 15 cm radius.
  for (const Lamp& lamp : lamps) {
    Object base;
    base.pose = {lamp.position.x, lamp.position.y, 0};
    base.radius = kLampBaseRadius;
    result.push_back(base.footprint());
  }
  return result;
}

World parseWorld(std::string_view text, const std::string& origin) {
  return WorldReader(origin).read(text);
}

World loadWorldFile(const std::string& path) {
  return parseWorld(components::readTextFile(path, "world file"), path);
}

}  // namespace peis::sim
