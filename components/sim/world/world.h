// World: the static description of a simulated home as read from its YAML
// file (docs/components/sim-world-file.md): rooms, walls, windows with
// blinds, furniture, lamps, objects, people, robots, ceiling cameras and
// named places. A plain value; the state that changes while the simulation
// runs is in simulation.h.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "camera/calibration.h"
#include "sim/world/geometry.h"

namespace peis::sim {

struct Colour {
  std::uint8_t r = 128, g = 128, b = 128;
  bool operator==(const Colour&) const = default;
};

struct Room {
  std::string name;
  Polygon polygon;
  Colour colour{200, 190, 170};
};

// A polyline of wall segments, each a box of `thickness` and `height`.
struct Wall {
  std::vector<Vec2> points;
  double thickness = 0.1;
  double height = 2.4;
  Colour colour{225, 222, 215};
};

// A window in a wall: daylight enters through the rectangle from `from` to
// `to` between heights `sill` and `top`, attenuated by its blind (if any).
struct Window {
  std::string name;
  Vec2 from, to;
  double sill = 0.9, top = 2.1;
  std::string blind;  // the blind's name; empty = no blind
  double tilt = 100;  // the blind's initial tilt: 0 closed .. 100 open
};

struct Furniture {
  std::string name;
  Polygon polygon;
  double height = 0.5;
  Colour colour{150, 140, 130};
};

inline constexpr double kLampBaseRadius = 0.15;

struct Lamp {
  std::string name;
  Vec2 position;
  double height = 1.6;
  double maxCandela = 150;  // luminous intensity at level 100
  double level = 0;         // initial level 0..100
  Colour colour{210, 205, 190};
};

// A thing on the floor: a disk (radius) or a box (size, theta). Movable
// objects are pushed by robots allowed to push their weight.
struct Object {
  std::string name;
  Pose2 pose;
  double radius = 0;  // > 0: a disk
  Vec2 size;          // a box when radius is 0
  double height = 0.3;
  double weightKg = 1;
  bool movable = false;
  Colour colour{160, 140, 110};
  // The radius of the disk used for collisions.
  double collisionRadius() const;
  Polygon footprint() const;
};

struct Person {
  std::string name;
  Pose2 pose;
  std::string state = "awake";  // asleep | awake
  double hearingM = 3.0;
  Colour colour{230, 190, 160};
};

struct OdometryNoise {
  double trans = 0.02;  // fraction of the distance travelled
  double rot = 0.02;    // fraction of the angle turned
  double drift = 0.01;  // radians of heading error per metre travelled
};

struct Hat {
  Colour colour{220, 30, 30};
  double radius = 0.1;
  double thickness = 0.02;
};

struct Robot {
  std::string name;
  std::string driver;  // the name of its driver PEIS (default <name>-base)
  std::optional<int> driverId;
  Pose2 start;
  double radius = 0.2;
  double height = 0.5;
  double maxSpeed = 0.5, maxTurn = 1.5;       // m/s, rad/s
  double maxAccel = 1.0, maxTurnAccel = 3.0;  // m/s², rad/s²
  double pushKg = 0;                          // heaviest movable object it pushes
  double cmdTimeout = 1.0;                    // s without VelCommand -> stop
  double batteryHours = 4;                    // hours of driving on a full battery
  OdometryNoise odometryNoise;
  std::vector<double> sonarAngles;  // radians in the robot frame
  double sonarMaxRange = 3.0;
  Hat hat;
  Colour colour{90, 90, 95};
  // Height of the hat's top surface (what the ceiling cameras see).
  double hatTop() const { return height + hat.thickness; }
};

struct Place {
  std::string name;
  Pose2 pose;
};

struct World {
  std::string name;
  std::string origin;      // the file it came from
  std::string sourceText;  // the YAML as read (published as physics.world)
  Vec2 size{10, 10};       // the map covers [0, size.x] x [0, size.y]
  double resolution = 0.05;
  double daylightLux = 8000;
  double ambientLux = 5;
  std::vector<Room> rooms;
  std::vector<Wall> walls;
  std::vector<Window> windows;
  std::vector<Furniture> furniture;
  std::vector<Lamp> lamps;
  std::vector<Object> objects;
  std::vector<Person> people;
  std::vector<Robot> robots;
  std::vector<camera::CameraSpec> cameras;
  std::vector<Place> places;

  bool insideMap(Vec2 p) const { return p.x >= 0 && p.y >= 0 && p.x <= size.x && p.y <= size.y; }
  const Robot* robot(std::string_view name) const;
  const Place* place(std::string_view name) const;
  const camera::CameraSpec* camera(std::string_view name) const;
  // The room containing `p`, or nullptr.
  const Room* roomAt(Vec2 p) const;
  // Walls as boxes and furniture: what the map and collisions see.
  std::vector<Polygon> obstacles() const;
};

// Reads a world file; Error(InvalidConfig) "file:line: problem" when it is
// broken (docs/components/sim-world-file.md lists the checks).
World loadWorldFile(const std::string& path);
World parseWorld(std::string_view text, const std::string& origin);

}  // namespace peis::sim
