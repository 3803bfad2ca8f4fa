// The changing state of a simulated home and its step (simulation.h).
#include "sim/world/simulation.h"

#include <algorithm>
#include <cmath>

namespace peis::sim {

Simulation::Simulation(World world, std::uint32_t seed)
    : world_(std::move(world)), rng_(seed), obstacles_(world_.obstacles()) {
  for (const Polygon& p : obstacles_) {
    Vec2 lo{INFINITY, INFINITY}, hi{-INFINITY, -INFINITY};
    for (const Vec2 q : p) {
      lo = {std::min(lo.x, q.x), std::min(lo.y, q.y)};
      hi = {std::max(hi.x, q.x), std::max(hi.y, q.y)};
    }
    obstacleBoxes_.emplace_back(lo, hi);
  }
  for (const Robot& r : world_.robots) {
    RobotState state;
    state.pose = r.start;
    state.odometry = r.start;  // the driver is told where it was switched on
    state.trail.push_back(r.start.position());
    robots_.push_back(state);
  }
  for (const Object& o : world_.objects) objects_.push_back(o.pose);
  for (const Person& p : world_.people) people_.push_back(p.state);
  light_ = initialLightState(world_);
}

std::optional<std::size_t> Simulation::robotIndex(std::string_view name) const {
  for (std::size_t i = 0; i < world_.robots.size(); ++i)
    if (world_.robots[i].name == name) return i;
  return std::nullopt;
}

std::optional<std::size_t> Simulation::objectIndex(std::string_view name) const {
  for (std::size_t i = 0; i < world_.objects.size(); ++i)
    if (world_.objects[i].name == name) return i;
  return std::nullopt;
}

void Simulation::command(std::size_t robot, Velocity velocity) {
  RobotState& state = robots_.at(robot);
  state.command = clampCommand(velocity, DriveLimits::of(world_.robots[robot]));
  state.commandAge = 0;
}

Speech Simulation::talk(std::size_t robot, std::string text) {
  Speech speech{world_.robots.at(robot).name, robots_[robot].pose, std::move(text), time_, {}};
  for (std::size_t i = 0; i < world_.people.size(); ++i) {
    const Person& person = world_.people[i];
    if (people_[i] == "asleep" &&
        (person.pose.position() - speech.at.position()).norm() <= person.hearingM) {
      people_[i] = "awake";
      speech.woke.push_back(person.name);
    }
  }
  return speech;
}

bool Simulation::staticFree(Vec2 c, double radius) const {
  if (c.x - radius < 0 || c.y - radius < 0 || c.x + radius > world_.size.x ||
      c.y + radius > world_.size.y)
    return false;
  for (std::size_t i = 0; i < obstacles_.size(); ++i) {
    const auto& [lo, hi] = obstacleBoxes_[i];
    if (c.x + radius < lo.x || c.y + radius < lo.y || c.x - radius > hi.x || c.y - radius > hi.y)
      continue;
    if (insidePolygon(obstacles_[i], c) || distanceToBoundary(obstacles_[i], c) < radius)
      return false;
  }
  return true;
}

bool Simulation::diskFree(Vec2 c, double radius, std::optional<std::size_t> robot,
                          std::optional<std::size_t> object) const {
  if (!staticFree(c, radius)) return false;
  for (std::size_t i = 0; i < robots_.size(); ++i)
    if (i != robot && (robots_[i].pose.position() - c).norm() < radius + world_.robots[i].radius)
      return false;
  for (std::size_t i = 0; i < objects_.size(); ++i)
    if (world_.objects[i].movable && i != object &&
        (objects_[i].position() - c).norm() < radius + world_.objects[i].collisionRadius())
      return false;
  return true;
}

bool Simulation::tryPush(std::size_t index, Vec2 robotAt) {
  const Robot& spec = world_.robots[index];
  if (!staticFree(robotAt, spec.radius)) return false;
  for (std::size_t i = 0; i < robots_.size(); ++i)
    if (i != index &&
        (robots_[i].pose.position() - robotAt).norm() < spec.radius + world_.robots[i].radius)
      return false;
  // Every movable object the robot would overlap must be light enough and
  // have room to move away from the robot.
  std::vector<std::pair<std::size_t, Vec2>> moves;
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    const Object& object = world_.objects[i];
    if (!object.movable) continue;
    const Vec2 away = objects_[i].position() - robotAt;
    const double reach = spec.radius + object.collisionRadius();
    if (away.norm() >= reach) continue;
    if (object.weightKg > spec.pushKg) return false;
    const Vec2 direction = away.norm() > 1e-9 ? away * (1.0 / away.norm())
                                              : Vec2{std::cos(robots_[index].pose.theta),
                                                     std::sin(robots_[index].pose.theta)};
    const Vec2 to = robotAt + direction * (reach + 1e-4);
    if (!diskFree(to, object.collisionRadius(), index, i)) return false;
    moves.emplace_back(i, to);
  }
  for (const auto& [i, to] : moves) objects_[i] = {to.x, to.y, objects_[i].theta};
  return true;
}

void Simulation::stepRobot(std::size_t index, double dt) {
  const Robot& spec = world_.robots[index];
  RobotState& state = robots_[index];
  state.commandAge += dt;
  Velocity target = state.commandAge <= spec.cmdTimeout ? state.command : Velocity{};
  if (state.battery <= 0) target = {};
  state.velocity = approach(state.velocity, target, DriveLimits::of(spec), dt);

  const Pose2 before = state.pose;
  Pose2 next = integrate(before, state.velocity, dt);
  const bool moves = (next.position() - before.position()).norm() > 1e-12;
  if (moves && !tryPush(index, next.position())) {
    // Blocked: the robot may still turn in place; its wheels stall.
    next = {before.x, before.y, next.theta};
    state.velocity.v = 0;
    state.bumper = true;
  } else if (moves) {
    state.bumper = false;
  }
  state.pose = next;

  const Vec2 moved = next.position() - before.position();
  const double forward = moved.dot({std::cos(before.theta), std::sin(before.theta)});
  const OdometryStep truth{moved.norm() * (forward < 0 ? -1 : 1),
                           normalizeAngle(next.theta - before.theta)};
  const OdometryStep measured = noisy(truth, spec.odometryNoise, rng_);
  state.odometry = accumulate(state.odometry, measured);
  state.measured = {measured.distance / dt, measured.turn / dt};
  state.distance += std::abs(truth.distance);

  // Idle draw is a fifth of full-speed draw.
  const double draw = 0.2 + 0.8 * std::abs(state.velocity.v) / spec.maxSpeed;
  state.battery = std::max(0.0, state.battery - 100.0 * draw * dt / (spec.batteryHours * 3600));

  if ((next.position() - state.trail.back()).norm() >= 0.02 && state.trail.size() < 200000)
    state.trail.push_back(next.position());
}

void Simulation::step(double dt) {
  while (dt > 1e-12) {
    const double slice = std::min(dt, 0.1);
    for (std::size_t i = 0; i < robots_.size(); ++i) stepRobot(i, slice);
    time_ += slice;
    dt -= slice;
  }
}

double Simulation::castRay(Vec2 origin, double angle, double maxRange,
                           std::optional<std::size_t> self) const {
  const Vec2 direction{std::cos(angle), std::sin(angle)};
  double best = maxRange;
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const Polygon& p = obstacles_[k];
    for (std::size_t i = 0, j = p.size() - 1; i < p.size(); j = i++)
      if (auto t = raySegment(origin, direction, p[j], p[i]); t && *t < best) best = *t;
  }
  const auto circle = [&](Vec2 centre, double radius) {
    const Vec2 to = centre - origin;
    const double along = to.dot(direction);
    const double miss2 = to.dot(to) - along * along;
    if (miss2 > radius * radius) return;
    const double t = along - std::sqrt(radius * radius - miss2);
    if (t >= 0 && t < best) best = t;
  };
  for (std::size_t i = 0; i < robots_.size(); ++i)
    if (i != self) circle(robots_[i].pose.position(), world_.robots[i].radius);
  for (std::size_t i = 0; i < objects_.size(); ++i)
    if (world_.objects[i].movable)
      circle(objects_[i].position(), world_.objects[i].collisionRadius());
  // The map's edge stops every ray.
  for (const auto& [a, b] : {std::pair{Vec2{0, 0}, Vec2{world_.size.x, 0}},
                             std::pair{Vec2{world_.size.x, 0}, world_.size},
                             std::pair{world_.size, Vec2{0, world_.size.y}},
                             std::pair{Vec2{0, world_.size.y}, Vec2{0, 0}}})
    if (auto t = raySegment(origin, direction, a, b); t && *t < best) best = *t;
  return best;
}

std::vector<double> Simulation::sonar(std::size_t index) {
  const Robot& spec = world_.robots.at(index);
  const RobotState& state = robots_[index];
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<double> ranges;
  for (double angle : spec.sonarAngles) {
    const double limit = spec.sonarMaxRange + spec.radius;
    const double hit = castRay(state.pose.position(), state.pose.theta + angle, limit, index);
    if (hit >= limit) {
      ranges.push_back(spec.sonarMaxRange);
      continue;
    }
    const double range = std::max(0.0, hit - spec.radius);
    ranges.push_back(
        std::clamp(range + (0.01 + 0.01 * range) * unit(rng_), 0.0, spec.sonarMaxRange));
  }
  return ranges;
}

}  // namespace peis::sim
