// The PEIS shell of the simulated home (world_node.h).
#include "world_node.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "peis/descriptor.h"
#include "peis/error.h"
#include "sim/world/occupancy_grid.h"
#include "sim/world/scene.h"
#include "world_descriptor.h"

namespace peis::sim {
namespace {

constexpr auto kTickPeriod = std::chrono::milliseconds(10);
constexpr int kMaxStepsPerTick = 400;

std::string fixed(double v, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
  return buffer;
}

std::string poseText(Pose2 p) {
  return fixed(p.x, 4) + " " + fixed(p.y, 4) + " " + fixed(p.theta, 5);
}

std::optional<double> number(std::string_view text) {
  std::istringstream in{std::string(text)};
  double value = 0;
  std::string rest;
  if (!(in >> value) || (in >> rest) || !std::isfinite(value)) return std::nullopt;
  return value;
}

// Numbers of a "X1 Y1 X2 Y2 ..." text (at most `limit` of them).
std::vector<double> numbersOf(std::string_view text, std::size_t limit) {
  std::istringstream in{std::string(text)};
  std::vector<double> values;
  double v = 0;
  while (values.size() < limit && in >> v && std::isfinite(v)) values.push_back(v);
  return values;
}

bool readOnly(const std::string& key) {
  return key.rfind("physics.", 0) == 0 || key.rfind("place.", 0) == 0 ||
         key.rfind("room.", 0) == 0 || key.rfind("sim.", 0) == 0 || key.rfind("map", 0) == 0 ||
         key == "places" || key == "rooms" || key == "picture";
}

}  // namespace

struct WorldNode::Reading {
  double time = 0;
  Timestamp at;
  struct Robot {
    std::optional<std::pair<Pose2, Velocity>> odometry;
    std::optional<std::vector<double>> sonar;
    std::optional<double> battery;
    bool bumper = false;
  };
  std::vector<Robot> robots;
  std::optional<std::string> scene;
  bool clock = false;
  std::vector<std::pair<std::string, double>> light;
  std::vector<std::pair<std::string, std::string>> objects, people;
  std::optional<std::string> quit;
};

WorldNode::WorldNode(WorldConfig config, World world)
    : config_(std::move(config)), sim_(std::move(world), config_.seed), light_(sim_.world()) {
  scene_.period = 1.0 / config_.sceneHz;
  for (const auto& [key, source] : config_.bindings) {
    const auto inputs = physicsInputs();
    if (std::find(inputs.begin(), inputs.end(), key) == inputs.end()) {
      std::string known;
      for (const auto& k : inputs) known += (known.empty() ? "" : ", ") + k;
      throw Error(ErrorCode::InvalidArgument,
                  "--bind " + key + ": not a physics input of this world (known: " + known + ")");
    }
    bindings_.push_back({key, parseFullName(source), false});
  }
  kernel_ = std::make_unique<Kernel>(config_.peis);
  startStamp_ = systemNow();
  component_ = std::make_unique<Component>(
      *kernel_, "sim-world", Descriptor::fromYaml(kSimWorldDescriptor, "sim-world.yaml"));
  installGate();
  publishStatic();

  const World& w = sim_.world();
  for (std::size_t i = 0; i < w.robots.size(); ++i) {
    Options options = config_.peis;
    options.name = w.robots[i].driver;
    options.id = w.robots[i].driverId ? std::optional<PeisId>(*w.robots[i].driverId) : std::nullopt;
    options.port = 0;
    options.setTuples.clear();
    drivers_.push_back(std::make_unique<DriverNode>(
        options, w.robots[i],
        [this, i](Velocity v) {
          std::lock_guard lock(mu_);
          sim_.command(i, v);
        },
        [this, i](std::string text) { onTalk(i, std::move(text)); }));
  }

  callbacks_.push_back(kernel_->onChange(Pattern("physics.**", kernel_->id()),
                                         [this](const Tuple& t) { onPhysicsInput(t); }));
  callbacks_.push_back(
      kernel_->onChange(Pattern("picture.request", kernel_->id()), [this](const Tuple&) {
        WriteOptions png;
        png.mimetype = "image/png";
        png.encoding = Encoding::Binary;
        double time = 0;
        {
          std::lock_guard lock(mu_);
          time = sim_.time();
        }
        png.ts_user = stamp(time);
        kernel_->set("picture", picture(), png);
      }));
  for (const char* pattern : {"position.*", "path.*"}) {
    const bool isPath = std::string(pattern) == "path.*";
    kernel_->subscribe(Pattern(pattern));
    callbacks_.push_back(kernel_->onChange(Pattern(pattern), [this, isPath](const Tuple& t) {
      if (t.owner != kernel_->id()) onEstimate(t, isPath);
    }));
  }
  anchorWall_ = std::chrono::steady_clock::now();
  tickTimer_ = kernel_->every(kTickPeriod, [this] { tick(); });
  if (!bindings_.empty())
    bindTimer_ = kernel_->every(std::chrono::milliseconds(200), [this] { bindPending(); });
  component_->start();
  say(0, "world '" + w.name + "' from " + w.origin + ": " + std::to_string(w.robots.size()) +
             " robots, speed " + fixed(config_.speed, 2));
}

WorldNode::~WorldNode() {
  if (tickTimer_) kernel_->cancelTimer(*tickTimer_);
  if (bindTimer_) kernel_->cancelTimer(*bindTimer_);
  for (auto handle : callbacks_) kernel_->removeCallback(handle);
  drivers_.clear();
  component_.reset();
  kernel_.reset();
}

std::vector<std::string> WorldNode::physicsInputs() const {
  std::vector<std::string> keys{"physics.daylight"};
  for (const Window& w : sim_.world().windows)
    if (!w.blind.empty()) keys.push_back("physics.blind." + w.blind + ".tilt");
  for (const Lamp& l : sim_.world().lamps) keys.push_back("physics.lamp." + l.name + ".level");
  return keys;
}

Timestamp WorldNode::stamp(double simTime) const {
  return startStamp_ +
         std::chrono::microseconds(static_cast<std::int64_t>(std::llround(simTime * 1e6)));
}

void WorldNode::say(double simTime, const std::string& what) {
  std::printf("%9.2fs  world  %s\n", simTime, what.c_str());
  std::fflush(stdout);
}

void WorldNode::installGate() {
  const auto inputs = physicsInputs();
  kernel_->setWriteGate([inputs](const Tuple& t, PeisId, const WriteDecision& decide) {
    if (std::find(inputs.begin(), inputs.end(), t.key) != inputs.end()) {
      const auto value = number(t.data);
      const double high = t.key == "physics.daylight" ? 200000 : 100;
      if (!value || *value < 0 || *value > high) {
        decide(Error(ErrorCode::Refused, t.key + " takes a number in 0.." + fixed(high, 0) +
                                             ", not '" + t.data.substr(0, 40) + "'"));
        return true;
      }
      return false;
    }
    if (readOnly(t.key)) {
      decide(Error(ErrorCode::Refused,
                   t.key + " is the world's; of its keys only the physics inputs and "
                           "picture.request take writes"));
      return true;
    }
    return false;
  });
}

void WorldNode::publishStatic() {
  const World& w = sim_.world();
  const OccupancyGrid grid = OccupancyGrid::fromWorld(w);
  WriteOptions pgm;
  pgm.mimetype = "image/x-portable-graymap";
  pgm.encoding = Encoding::Binary;
  kernel_->set("map", grid.toPgm(), pgm);
  kernel_->set("map.info", grid.info());
  std::string names;
  for (const Place& p : w.places) {
    kernel_->set("place." + p.name, poseText(p.pose));
    names += (names.empty() ? "" : " ") + p.name;
  }
  kernel_->set("places", names);
  names.clear();
  for (const Room& room : w.rooms) {
    std::string polygon;
    for (const Vec2 p : room.polygon)
      polygon += (polygon.empty() ? "" : " ") + fixed(p.x, 4) + " " + fixed(p.y, 4);
    kernel_->set("room." + room.name, polygon);
    names += (names.empty() ? "" : " ") + room.name;
  }
  kernel_->set("rooms", names);
  WriteOptions yaml;
  yaml.mimetype = "application/yaml";
  kernel_->set("physics.world", w.sourceText, yaml);
  kernel_->set("sim.speed", fixed(config_.speed, 3));
  kernel_->set("sim.tick", fixed(config_.tick, 3));
  const LightState& light = sim_.light();
  kernel_->set("physics.daylight", fixed(light.daylightLux, 1));
  for (std::size_t i = 0; i < w.windows.size(); ++i)
    if (!w.windows[i].blind.empty())
      kernel_->set("physics.blind." + w.windows[i].blind + ".tilt", fixed(light.blindTilt[i], 1));
  for (std::size_t i = 0; i < w.lamps.size(); ++i)
    kernel_->set("physics.lamp." + w.lamps[i].name + ".level", fixed(light.lampLevel[i], 1));
}

void WorldNode::onPhysicsInput(const Tuple& t) {
  const auto value = number(t.data);
  if (!value) return;
  const World& w = sim_.world();
  std::string change;
  double time = 0;
  {
    std::lock_guard lock(mu_);
    LightState& light = sim_.light();
    time = sim_.time();
    if (t.key == "physics.daylight" && light.daylightLux != *value) {
      light.daylightLux = *value;
      change = "daylight " + fixed(*value, 0) + " lux";
    }
    for (std::size_t i = 0; i < w.windows.size(); ++i)
      if (!w.windows[i].blind.empty() && t.key == "physics.blind." + w.windows[i].blind + ".tilt" &&
          light.blindTilt[i] != *value) {
        light.blindTilt[i] = std::clamp(*value, 0.0, 100.0);
        change = w.windows[i].blind + " tilt " + fixed(*value, 0);
      }
    for (std::size_t i = 0; i < w.lamps.size(); ++i)
      if (t.key == "physics.lamp." + w.lamps[i].name + ".level" && light.lampLevel[i] != *value) {
        light.lampLevel[i] = std::clamp(*value, 0.0, 100.0);
        change = w.lamps[i].name + " level " + fixed(*value, 0);
      }
    if (!change.empty()) lightChanged_ = true;
  }
  if (!change.empty()) say(time, change);
}

void WorldNode::onEstimate(const Tuple& t, bool isPath) {
  const std::string robot = t.key.substr(t.key.find('.') + 1);
  const auto values = numbersOf(t.data, isPath ? 20000 : 2);
  std::lock_guard lock(mu_);
  if (!sim_.robotIndex(robot)) return;  // not a robot of this world
  if (isPath) {
    PlannedPath& path = paths_[{robot, t.owner}];
    path.robot = robot;
    path.by = std::to_string(t.owner);
    path.points.clear();
    for (std::size_t i = 0; i + 1 < values.size(); i += 2)
      path.points.push_back({values[i], values[i + 1]});
    return;
  }
  if (values.size() < 2) return;
  Estimate& e = estimates_[{robot, t.owner}];
  e.robot = robot;
  e.by = std::to_string(t.owner);
  e.position = {values[0], values[1]};
  if (e.trail.empty() || (e.trail.back() - e.position).norm() >= 0.02)
    if (e.trail.size() < 200000) e.trail.push_back(e.position);
}

void WorldNode::onTalk(std::size_t robot, std::string text) {
  Speech speech;
  {
    std::lock_guard lock(mu_);
    speech = sim_.talk(robot, std::move(text));
  }
  kernel_->set("physics.speech",
               speech.robot + " " + poseText(speech.at).substr(0, poseText(speech.at).rfind(' ')) +
                   " " + speech.text,
               WriteOptions{kDefaultMimetype, Encoding::Ascii, stamp(speech.time)});
  std::string line = speech.robot + " says '" + speech.text + "'";
  for (const auto& person : speech.woke) line += "; " + person + " wakes up";
  say(speech.time, line);
}

void WorldNode::bindPending() {
  bool all = true;
  for (Binding& b : bindings_) {
    if (b.bound) continue;
    PeisId owner = 0;
    try {
      owner = kernel_->resolveOwner(b.source.owner);
    } catch (const Error&) {
      all = false;  // not (yet) known: try again
      continue;
    }
    const std::string target = b.physicsKey;
    kernel_->subscribe(Pattern::exact(owner, b.source.key));
    callbacks_.push_back(
        kernel_->onChange(Pattern::exact(owner, b.source.key), [this, target](const Tuple& t) {
          if (auto v = number(t.data)) {
            const double high = target == "physics.daylight" ? 200000 : 100;
            kernel_->set(target, fixed(std::clamp(*v, 0.0, high), 1));
          } else {
            std::cerr << "peis-sim-world: --bind " << target << ": ignored '"
                      << t.data.substr(0, 40) << "' from " << t.fullName() << " (not a number)\n";
          }
        }));
    b.bound = true;
    double time = 0;
    {
      std::lock_guard lock(mu_);
      time = sim_.time();
    }
    say(time, "bound " + target + " to " + std::to_string(owner) + "." + b.source.key);
  }
  if (all && bindTimer_) {
    kernel_->cancelTimer(*bindTimer_);
    bindTimer_.reset();
  }
}

void WorldNode::tick() {
  Reading r;
  {
    std::lock_guard lock(mu_);
    const auto now = std::chrono::steady_clock::now();
    const double target =
        anchorSim_ + std::chrono::duration<double>(now - anchorWall_).count() * config_.speed;
    int steps = 0;
    while (sim_.time() + config_.tick / 2 < target && steps < kMaxStepsPerTick) {
      sim_.step(config_.tick);
      ++steps;
    }
    // A machine too slow for the speed asked: simulated time slips.
    if (target - sim_.time() > 0.25) {
      if (!warnedLag_)
        std::cerr << "peis-sim-world: cannot keep up with --speed " << config_.speed
                  << "; simulated time runs slower\n";
      warnedLag_ = true;
      anchorWall_ = now;
      anchorSim_ = sim_.time();
    }
    const double t = sim_.time();
    r.time = t;
    r.at = stamp(t);
    const bool odometry = odometry_.due(t), sonar = sonar_.due(t), battery = battery_.due(t);
    for (std::size_t i = 0; i < sim_.world().robots.size(); ++i) {
      const RobotState& s = sim_.robot(i);
      Reading::Robot robot;
      if (odometry) robot.odometry = std::make_pair(s.odometry, s.measured);
      if (sonar) robot.sonar = sim_.sonar(i);
      if (battery) robot.battery = s.battery;
      robot.bumper = s.bumper;
      r.robots.push_back(robot);
    }
    if (scene_.due(t)) {
      r.scene = formatScene(sceneOf(sim_));
      const World& w = sim_.world();
      for (std::size_t i = 0; i < w.objects.size(); ++i) {
        const Pose2 p = sim_.objectPose(i);
        auto known = publishedObjects_.find(w.objects[i].name);
        if (known == publishedObjects_.end() ||
            (known->second.position() - p.position()).norm() > 1e-3 ||
            std::abs(known->second.theta - p.theta) > 1e-3) {
          publishedObjects_[w.objects[i].name] = p;
          r.objects.emplace_back(w.objects[i].name,
                                 poseText(p) + " " + fixed(w.objects[i].weightKg, 3));
        }
      }
      for (std::size_t i = 0; i < w.people.size(); ++i)
        if (publishedPeople_[w.people[i].name] != sim_.personState(i)) {
          publishedPeople_[w.people[i].name] = sim_.personState(i);
          r.people.emplace_back(w.people[i].name, sim_.personState(i));
        }
    }
    r.clock = clock_.due(t);
    if (lightTimer_.due(t) || lightChanged_) {
      const World& w = sim_.world();
      const auto consider = [&](const std::string& name, Vec2 p, double z) {
        const double lux = light_.illuminance(sim_.light(), p, z);
        auto known = publishedLight_.find(name);
        if (known == publishedLight_.end() ||
            std::abs(known->second - lux) > 0.01 * std::max(1.0, known->second)) {
          publishedLight_[name] = lux;
          r.light.emplace_back(name, lux);
        }
      };
      for (const Furniture& f : w.furniture) consider(f.name, centroid(f.polygon), f.height);
      for (std::size_t i = 0; i < w.objects.size(); ++i)
        consider(w.objects[i].name, sim_.objectPose(i).position(), w.objects[i].height);
      for (const Person& p : w.people) consider(p.name, p.pose.position(), 0.5);
      lightChanged_ = false;
    }
    if (config_.duration && t >= *config_.duration - 1e-9) r.quit = "duration reached";
  }
  publish(r);
}

void WorldNode::publish(const Reading& r) {
  for (std::size_t i = 0; i < r.robots.size(); ++i) {
    DriverNode& driver = *drivers_[i];
    const auto& robot = r.robots[i];
    if (robot.odometry) driver.publishOdometry(robot.odometry->first, robot.odometry->second, r.at);
    if (robot.sonar) driver.publishSonar(*robot.sonar, r.at);
    if (robot.battery) driver.publishBattery(*robot.battery, r.at);
    driver.publishBumper(robot.bumper, r.at);
  }
  WriteOptions at;
  at.ts_user = r.at;
  if (r.scene) kernel_->set("physics.scene", *r.scene, at);
  for (const auto& [name, lux] : r.light) kernel_->set("physics.light." + name, fixed(lux, 1), at);
  for (const auto& [name, text] : r.objects) kernel_->set("physics.object." + name, text, at);
  for (const auto& [name, state] : r.people) kernel_->set("physics.person." + name, state, at);
  if (r.clock) kernel_->set("sim.time", fixed(r.time, 3), at);
  if (r.quit && !kernel_->quitRequested()) {
    say(r.time, *r.quit);
    kernel_->quit(*r.quit);
  }
}

std::string WorldNode::picture() {
  std::map<PeisId, std::string> names;
  for (const auto& peer : kernel_->peers()) names[peer.id] = peer.name;
  std::lock_guard lock(mu_);
  std::vector<Estimate> estimates;
  for (const auto& [key, e] : estimates_) {
    Estimate copy = e;
    if (auto n = names.find(key.second); n != names.end() && !n->second.empty())
      copy.by = n->second;
    estimates.push_back(std::move(copy));
  }
  std::vector<PlannedPath> paths;
  for (const auto& [key, p] : paths_) paths.push_back(p);
  TopDownOptions options;
  options.pixelsPerMetre = config_.pictureScale;
  options.caption = "t = " + fixed(sim_.time(), 1) + " s";
  return renderTopDown(sim_, light_, estimates, paths, options);
}

std::string WorldNode::run() {
  const std::string why = kernel_->run();
  if (tickTimer_) kernel_->cancelTimer(*tickTimer_);
  tickTimer_.reset();
  if (!config_.picturePath.empty()) {
    std::ofstream out(config_.picturePath, std::ios::binary);
    const std::string png = picture();
    out.write(png.data(), static_cast<std::streamsize>(png.size()));
    if (out) {
      std::lock_guard lock(mu_);
      say(sim_.time(), "picture written to " + config_.picturePath);
    } else {
      std::cerr << "peis-sim-world: cannot write the picture to " << config_.picturePath << "\n";
    }
  }
  return why;
}

}  // namespace peis::sim
