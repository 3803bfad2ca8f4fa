// The light model (light_model.h).
#include "sim/world/light_model.h"

#include <algorithm>
#include <cmath>

namespace peis::sim {
namespace {

constexpr int kSamplesAlong = 8;
constexpr int kSamplesUp = 4;
constexpr double kBounce = 0.5;

}  // namespace

LightState initialLightState(const World& world) {
  LightState state;
  state.daylightLux = world.daylightLux;
  for (const Window& w : world.windows) state.blindTilt.push_back(w.blind.empty() ? 100 : w.tilt);
  for (const Lamp& l : world.lamps) state.lampLevel.push_back(l.level);
  return state;
}

double blindOpening(double tilt) { return 0.05 + 0.95 * std::clamp(tilt, 0.0, 100.0) / 100.0; }

LightModel::LightModel(const World& world, double mapResolution)
    : world_(&world), cell_(mapResolution) {
  for (const Wall& wall : world.walls)
    for (std::size_t i = 1; i < wall.points.size(); ++i)
      wallSegments_.emplace_back(wall.points[i - 1], wall.points[i]);
  const Vec2 middleOfMap{world.size.x / 2, world.size.y / 2};
  for (const Window& w : world.windows) {
    Source s{w.from, w.to, {}, w.sill, w.top};
    const Vec2 along = (w.to - w.from) * (1.0 / (w.to - w.from).norm());
    Vec2 normal{-along.y, along.x};
    // Inward: the side a room is on, else the side of the map's middle.
    const Vec2 middle = (w.from + w.to) * 0.5;
    const bool roomLeft = world.roomAt(middle + normal * 0.2) != nullptr;
    const bool roomRight = world.roomAt(middle - normal * 0.2) != nullptr;
    if (roomRight && !roomLeft) normal = normal * -1;
    if (roomLeft == roomRight && (middleOfMap - middle).dot(normal) < 0) normal = normal * -1;
    s.inward = normal;
    windows_.push_back(s);
  }
  columns_ = std::max(1, static_cast<int>(std::ceil(world.size.x / cell_)) + 1);
  rows_ = std::max(1, static_cast<int>(std::ceil(world.size.y / cell_)) + 1);
  const auto fill = [&](auto term) {
    std::vector<float> map(static_cast<std::size_t>(columns_) * rows_);
    for (int r = 0; r < rows_; ++r)
      for (int c = 0; c < columns_; ++c)
        map[static_cast<std::size_t>(r) * columns_ + c] =
            static_cast<float>(term(Vec2{c * cell_, r * cell_}));
    return map;
  };
  for (std::size_t i = 0; i < windows_.size(); ++i) {
    windowMaps_.push_back(fill([&](Vec2 p) { return directWindowTerm(i, p, 0); }));
    windowBounce_.push_back(bounced(windowMaps_.back()));
  }
  for (std::size_t i = 0; i < world.lamps.size(); ++i) {
    lampMaps_.push_back(fill([&](Vec2 p) { return directLampTerm(i, p, 0); }));
    lampBounce_.push_back(bounced(lampMaps_.back()));
  }
  // Bake the bounced light into the floor maps.
  const auto bake = [&](std::vector<float>& map, const std::vector<double>& perRoom) {
    for (int r = 0; r < rows_; ++r)
      for (int c = 0; c < columns_; ++c)
        map[static_cast<std::size_t>(r) * columns_ + c] +=
            static_cast<float>(bouncedIn(perRoom, Vec2{c * cell_, r * cell_}));
  };
  for (std::size_t i = 0; i < windowMaps_.size(); ++i) bake(windowMaps_[i], windowBounce_[i]);
  for (std::size_t i = 0; i < lampMaps_.size(); ++i) bake(lampMaps_[i], lampBounce_[i]);
}

std::vector<double> LightModel::bounced(const std::vector<float>& directMap) const {
  std::vector<double> perRoom;
  for (const Room& room : world_->rooms) {
    double sum = 0;
    int count = 0;
    for (int r = 0; r < rows_; ++r)
      for (int c = 0; c < columns_; ++c)
        if (insidePolygon(room.polygon, Vec2{c * cell_, r * cell_})) {
          sum += directMap[static_cast<std::size_t>(r) * columns_ + c];
          ++count;
        }
    perRoom.push_back(count > 0 ? kBounce * sum / count : 0.0);
  }
  return perRoom;
}

double LightModel::bouncedIn(const std::vector<double>& perRoom, Vec2 p) const {
  for (std::size_t i = 0; i < world_->rooms.size(); ++i)
    if (insidePolygon(world_->rooms[i].polygon, p)) return perRoom[i];
  return 0;
}

double LightModel::bouncedWindowTerm(std::size_t window, Vec2 p) const {
  return bouncedIn(windowBounce_.at(window), p);
}

double LightModel::bouncedLampTerm(std::size_t lamp, Vec2 p) const {
  return bouncedIn(lampBounce_.at(lamp), p);
}

double LightModel::windowTerm(std::size_t window, Vec2 p, double z) const {
  return directWindowTerm(window, p, z) + bouncedWindowTerm(window, p);
}

double LightModel::lampTerm(std::size_t lamp, Vec2 p, double z) const {
  return directLampTerm(lamp, p, z) + bouncedLampTerm(lamp, p);
}

bool LightModel::blocked(Vec2 from, Vec2 to, const Source* through) const {
  for (const auto& [a, b] : wallSegments_) {
    // The wall the window is in lets its light through.
    if (through != nullptr && distanceToSegment(through->a, a, b) < 1e-3 &&
        distanceToSegment(through->b, a, b) < 1e-3)
      continue;
    if (segmentsIntersect(from, to, a, b)) return true;
  }
  return false;
}

double LightModel::directWindowTerm(std::size_t index, Vec2 p, double z) const {
  const Source& s = windows_.at(index);
  if ((p - s.a).dot(s.inward) <= 1e-6) return 0;  // outside, or in the window's plane
  const Vec2 along = s.b - s.a;
  const double width = along.norm(), height = s.top - s.sill;
  const double area = width * height / (kSamplesAlong * kSamplesUp);
  const double luminance = 1.0 / M_PI;  // per lux of daylight, blind open
  double sum = 0;
  for (int i = 0; i < kSamplesAlong; ++i) {
    const Vec2 at = s.a + along * ((i + 0.5) / kSamplesAlong);
    if (blocked(at + s.inward * 1e-3, p, &s)) continue;
    for (int j = 0; j < kSamplesUp; ++j) {
      const double sz = s.sill + height * (j + 0.5) / kSamplesUp;
      const double dx = p.x - at.x, dy = p.y - at.y, dz = z - sz;
      const double d2 = dx * dx + dy * dy + dz * dz;
      const double d = std::sqrt(d2);
      const double cosWindow = (dx * s.inward.x + dy * s.inward.y) / d;
      const double cosSurface = -dz / d;  // light must come from above
      if (cosWindow <= 0 || cosSurface <= 0) continue;
      // A point right at the window sees at most half the sky's worth.
      sum += luminance * cosWindow * cosSurface * area / std::max(d2, 0.05);
    }
  }
  return std::min(sum, 0.5);
}

double LightModel::directLampTerm(std::size_t index, Vec2 p, double z) const {
  const Lamp& lamp = world_->lamps.at(index);
  const double dz = lamp.height - z;
  if (dz <= 0) return 0;
  if (blocked(lamp.position, p, nullptr)) return 0;
  const Vec2 d = p - lamp.position;
  const double d2 = d.dot(d) + dz * dz;
  return lamp.maxCandela * (dz / std::sqrt(d2)) / std::max(d2, 0.05);
}

double LightModel::illuminance(const LightState& state, Vec2 p, double z) const {
  double lux = world_->ambientLux;
  for (std::size_t i = 0; i < windows_.size(); ++i)
    lux += state.daylightLux * blindOpening(i < state.blindTilt.size() ? state.blindTilt[i] : 100) *
           windowTerm(i, p, z);
  for (std::size_t i = 0; i < world_->lamps.size(); ++i)
    lux += (i < state.lampLevel.size() ? state.lampLevel[i] : 0) / 100.0 * lampTerm(i, p, z);
  return lux;
}

double LightModel::mapValue(const std::vector<float>& map, Vec2 p) const {
  const double fx = std::clamp(p.x / cell_, 0.0, columns_ - 1.0);
  const double fy = std::clamp(p.y / cell_, 0.0, rows_ - 1.0);
  const int c = std::min(static_cast<int>(fx), columns_ - 2 < 0 ? 0 : columns_ - 2);
  const int r = std::min(static_cast<int>(fy), rows_ - 2 < 0 ? 0 : rows_ - 2);
  const double tx = columns_ > 1 ? fx - c : 0, ty = rows_ > 1 ? fy - r : 0;
  const auto at = [&](int rr, int cc) {
    rr = std::min(rr, rows_ - 1);
    cc = std::min(cc, columns_ - 1);
    return static_cast<double>(map[static_cast<std::size_t>(rr) * columns_ + cc]);
  };
  return (1 - ty) * ((1 - tx) * at(r, c) + tx * at(r, c + 1)) +
         ty * ((1 - tx) * at(r + 1, c) + tx * at(r + 1, c + 1));
}

double LightModel::floorIlluminance(const LightState& state, Vec2 p) const {
  double lux = world_->ambientLux;
  if (!world_->insideMap(p)) return lux;
  for (std::size_t i = 0; i < windowMaps_.size(); ++i)
    lux += state.daylightLux * blindOpening(i < state.blindTilt.size() ? state.blindTilt[i] : 100) *
           mapValue(windowMaps_[i], p);
  for (std::size_t i = 0; i < lampMaps_.size(); ++i)
    lux +=
        (i < state.lampLevel.size() ? state.lampLevel[i] : 0) / 100.0 * mapValue(lampMaps_[i], p);
  return lux;
}

}  // namespace peis::sim
