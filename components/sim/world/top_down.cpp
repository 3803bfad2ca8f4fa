// The top-down picture (top_down.h), drawn with OpenCV.
#include "sim/world/top_down.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace peis::sim {
namespace {

constexpr int kMargin = 30;

cv::Scalar bgr(Colour c, double scale = 1.0) {
  return cv::Scalar(std::min(255.0, c.b * scale), std::min(255.0, c.g * scale),
                    std::min(255.0, c.r * scale));
}

class Canvas {
 public:
  Canvas(const World& world, double scale)
      : scale_(scale),
        image_(static_cast<int>(std::ceil(world.size.y * scale)) + 2 * kMargin + 20,
               static_cast<int>(std::ceil(world.size.x * scale)) + 2 * kMargin, CV_8UC3,
               cv::Scalar(60, 60, 60)),
        height_(world.size.y) {}

  cv::Point at(Vec2 p) const {
    return {static_cast<int>(std::lround(kMargin + p.x * scale_)),
            static_cast<int>(std::lround(kMargin + 20 + (height_ - p.y) * scale_))};
  }
  int length(double metres) const {
    return std::max(1, static_cast<int>(std::lround(metres * scale_)));
  }
  std::vector<cv::Point> points(const std::vector<Vec2>& ps) const {
    std::vector<cv::Point> out;
    for (const Vec2 p : ps) out.push_back(at(p));
    return out;
  }
  void fill(const Polygon& p, cv::Scalar colour) {
    const std::vector<std::vector<cv::Point>> polys{points(p)};
    cv::fillPoly(image_, polys, colour, cv::LINE_AA);
  }
  void outline(const std::vector<Vec2>& p, cv::Scalar colour, int thickness, bool closed) {
    if (p.size() < 2) return;
    const std::vector<std::vector<cv::Point>> polys{points(p)};
    cv::polylines(image_, polys, closed, colour, thickness, cv::LINE_AA);
  }
  void text(const std::string& s, Vec2 p, cv::Scalar colour, double size = 0.4) {
    cv::putText(image_, s, at(p), cv::FONT_HERSHEY_SIMPLEX, size, cv::Scalar(0, 0, 0), 3,
                cv::LINE_AA);
    cv::putText(image_, s, at(p), cv::FONT_HERSHEY_SIMPLEX, size, colour, 1, cv::LINE_AA);
  }
  cv::Mat& image() { return image_; }
  double scale() const { return scale_; }

 private:
  double scale_;
  cv::Mat image_;
  double height_;
};

// Rooms, shaded by the light on the floor (so a closed blind shows).
void drawFloor(Canvas& canvas, const World& world, const LightModel& light,
               const LightState& state) {
  cv::Mat rooms(canvas.image().size(), CV_8UC3, cv::Scalar(0, 0, 0));
  cv::Mat mask(canvas.image().size(), CV_8UC1, cv::Scalar(0));
  for (const Room& room : world.rooms) {
    const std::vector<std::vector<cv::Point>> polys{canvas.points(room.polygon)};
    cv::fillPoly(rooms, polys, bgr(room.colour));
    cv::fillPoly(mask, polys, cv::Scalar(255));
  }
  // Light at 10 cm, stretched over the picture.
  const int columns = std::max(2, static_cast<int>(std::ceil(world.size.x / 0.1)));
  const int rows = std::max(2, static_cast<int>(std::ceil(world.size.y / 0.1)));
  cv::Mat shade(rows, columns, CV_32FC1);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c) {
      const Vec2 p{(c + 0.5) * world.size.x / columns,
                   world.size.y - (r + 0.5) * world.size.y / rows};
      shade.at<float>(r, c) =
          static_cast<float>(0.45 + 0.55 * std::min(1.0, light.floorIlluminance(state, p) / 500));
    }
  cv::Mat stretched(canvas.image().size(), CV_32FC1, cv::Scalar(1.0f));
  const cv::Rect floor(canvas.at({0, world.size.y}), canvas.at({world.size.x, 0}));
  cv::resize(shade, stretched(floor), floor.size(), 0, 0, cv::INTER_LINEAR);
  cv::Mat shade3;
  cv::merge(std::vector<cv::Mat>{stretched, stretched, stretched}, shade3);
  cv::Mat lit;
  rooms.convertTo(lit, CV_32FC3);
  lit = lit.mul(shade3);
  lit.convertTo(rooms, CV_8UC3);
  rooms.copyTo(canvas.image(), mask);
  for (const Room& room : world.rooms)
    canvas.text(room.name, room.polygon.front() + Vec2{0.1, 0.1}, {90, 90, 90}, 0.45);
}

void drawCameras(Canvas& canvas, const World& world) {
  for (const auto& camera : world.cameras) {
    const auto& c = camera.calibration;
    const Polygon view = fieldOfView(c, std::hypot(world.size.x, world.size.y) * 2);
    if (view.size() >= 3) {
      cv::Mat overlay = canvas.image().clone();
      const std::vector<std::vector<cv::Point>> polys{canvas.points(view)};
      cv::fillPoly(overlay, polys, cv::Scalar(200, 140, 60), cv::LINE_AA);
      cv::addWeighted(overlay, 0.12, canvas.image(), 0.88, 0, canvas.image());
      canvas.outline(view, cv::Scalar(200, 140, 60), 1, true);
    }
    const Vec2 at{c.position.x(), c.position.y()};
    cv::circle(canvas.image(), canvas.at(at), 5, cv::Scalar(200, 140, 60), cv::FILLED, cv::LINE_AA);
    canvas.text(c.name, at + Vec2{0.08, 0.08}, cv::Scalar(240, 190, 120));
  }
}

void drawRobot(Canvas& canvas, const Robot& spec, const RobotState& state) {
  std::vector<Vec2> trail = state.trail;
  trail.push_back(state.pose.position());
  canvas.outline(trail, bgr(spec.hat.colour, 0.8), 2, false);
  const cv::Point centre = canvas.at(state.pose.position());
  cv::circle(canvas.image(), centre, canvas.length(spec.radius), bgr(spec.colour), cv::FILLED,
             cv::LINE_AA);
  cv::circle(canvas.image(), centre, canvas.length(spec.hat.radius), bgr(spec.hat.colour),
             cv::FILLED, cv::LINE_AA);
  const Vec2 nose = state.pose.position() +
                    Vec2{std::cos(state.pose.theta), std::sin(state.pose.theta)} * spec.radius;
  cv::line(canvas.image(), centre, canvas.at(nose), cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  if (state.bumper)
    cv::circle(canvas.image(), centre, canvas.length(spec.radius) + 3, cv::Scalar(0, 0, 255), 2,
               cv::LINE_AA);
  char label[96];
  std::snprintf(label, sizeof label, "%s %.0f%%", spec.name.c_str(), state.battery);
  canvas.text(label, state.pose.position() + Vec2{spec.radius, spec.radius},
              cv::Scalar(255, 255, 255));
}

}  // namespace

Polygon fieldOfView(const camera::Calibration& c, double maxRange) {
  // Walk the image border; keep the floor points its rays reach.
  Polygon floor;
  const int steps = 16;
  const double w = c.width - 1, h = c.height - 1;
  std::vector<std::pair<double, double>> border;
  for (int i = 0; i < steps; ++i) border.emplace_back(w * i / steps, 0);
  for (int i = 0; i < steps; ++i) border.emplace_back(w, h * i / steps);
  for (int i = 0; i < steps; ++i) border.emplace_back(w - w * i / steps, h);
  for (int i = 0; i < steps; ++i) border.emplace_back(0, h - h * i / steps);
  for (const auto& [u, v] : border) {
    const Eigen::Vector3d d = c.rayDirection(u, v);
    double t = maxRange;
    if (d.z() < -1e-9) t = std::min(t, -c.position.z() / d.z());
    const Eigen::Vector3d p = c.position + t * d;
    if (d.z() < -1e-9 || t < maxRange)
      floor.push_back({p.x(), p.y()});
    else
      floor.push_back({c.position.x() + maxRange * d.x(), c.position.y() + maxRange * d.y()});
  }
  return floor;
}

std::string renderTopDown(const Simulation& simulation, const LightModel& light,
                          const std::vector<Estimate>& estimates,
                          const std::vector<PlannedPath>& paths, const TopDownOptions& options) {
  const World& world = simulation.world();
  Canvas canvas(world, options.pixelsPerMetre);
  drawFloor(canvas, world, light, simulation.light());
  drawCameras(canvas, world);
  for (const Furniture& f : world.furniture) {
    canvas.fill(f.polygon, bgr(f.colour));
    canvas.outline(f.polygon, bgr(f.colour, 0.6), 1, true);
    canvas.text(f.name, centroid(f.polygon) - Vec2{0.2, 0}, cv::Scalar(30, 30, 30));
  }
  for (const Wall& wall : world.walls)
    for (std::size_t i = 1; i < wall.points.size(); ++i)
      canvas.fill(thickSegment(wall.points[i - 1], wall.points[i], wall.thickness),
                  cv::Scalar(40, 40, 40));
  for (std::size_t i = 0; i < world.windows.size(); ++i) {
    const Window& w = world.windows[i];
    const double tilt = simulation.light().blindTilt[i];
    cv::line(canvas.image(), canvas.at(w.from), canvas.at(w.to),
             cv::Scalar(255, 220, 150) * blindOpening(tilt), 4, cv::LINE_AA);
    if (!w.blind.empty()) {
      char label[96];
      std::snprintf(label, sizeof label, "%s %.0f%%", w.blind.c_str(), tilt);
      canvas.text(label, (w.from + w.to) * 0.5 + Vec2{0.1, 0}, cv::Scalar(255, 230, 180));
    }
  }
  for (std::size_t i = 0; i < world.lamps.size(); ++i) {
    const Lamp& lamp = world.lamps[i];
    const double level = simulation.light().lampLevel[i];
    if (level > 0)
      cv::circle(canvas.image(), canvas.at(lamp.position), canvas.length(0.1 + 0.4 * level / 100),
                 cv::Scalar(80, 230, 255), 2, cv::LINE_AA);
    cv::circle(canvas.image(), canvas.at(lamp.position), canvas.length(0.1), bgr(lamp.colour),
               cv::FILLED, cv::LINE_AA);
    char label[96];
    std::snprintf(label, sizeof label, "%s %.0f%%", lamp.name.c_str(), level);
    canvas.text(label, lamp.position + Vec2{0.12, -0.05}, cv::Scalar(80, 230, 255));
  }
  for (std::size_t i = 0; i < world.objects.size(); ++i) {
    Object o = world.objects[i];
    o.pose = simulation.objectPose(i);
    canvas.fill(o.footprint(), bgr(o.colour));
    char label[96];
    std::snprintf(label, sizeof label, "%s %.1f kg", o.name.c_str(), o.weightKg);
    canvas.text(o.movable ? label : o.name, o.pose.position() + Vec2{0.15, -0.05},
                cv::Scalar(220, 220, 220));
  }
  for (std::size_t i = 0; i < world.people.size(); ++i) {
    const Person& p = world.people[i];
    cv::circle(canvas.image(), canvas.at(p.pose.position()), canvas.length(0.18), bgr(p.colour),
               cv::FILLED, cv::LINE_AA);
    canvas.text(p.name + " (" + simulation.personState(i) + ")", p.pose.position() + Vec2{0.2, 0},
                cv::Scalar(40, 40, 40));
  }
  for (const PlannedPath& path : paths) {
    const Robot* robot = world.robot(path.robot);
    canvas.outline(path.points, robot ? bgr(robot->hat.colour, 0.5) : cv::Scalar(200, 200, 200), 1,
                   false);
  }
  for (std::size_t i = 0; i < world.robots.size(); ++i)
    drawRobot(canvas, world.robots[i], simulation.robot(i));
  for (const Estimate& e : estimates) {
    const Robot* robot = world.robot(e.robot);
    const cv::Scalar colour = robot ? bgr(robot->hat.colour, 1.2) : cv::Scalar(255, 255, 255);
    canvas.outline(e.trail, colour, 1, false);
    const int radius = canvas.length(robot ? robot->radius : 0.2);
    cv::circle(canvas.image(), canvas.at(e.position), radius, colour, 1, cv::LINE_AA);
    cv::drawMarker(canvas.image(), canvas.at(e.position), colour, cv::MARKER_CROSS, radius, 1);
    canvas.text(e.robot + "@" + e.by, e.position + Vec2{-0.3, -0.35}, colour, 0.35);
  }
  cv::putText(canvas.image(), world.name + "  " + options.caption, {kMargin, 22},
              cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  std::vector<unsigned char> png;
  cv::imencode(".png", canvas.image(), png);
  return std::string(png.begin(), png.end());
}

}  // namespace peis::sim
