// The simulated ceiling camera's renderer (render_view.h).
#include "camera/render_view.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>

namespace peis::camera {
namespace {

using sim::Colour;
using sim::Polygon;
using sim::Vec2;

constexpr double kNear = 0.05;
constexpr int kShift = 4;  // sub-pixel bits for fillPoly
constexpr double kWallPiece = 0.3;

// A convex prism standing between heights z0 and z1 over `footprint`.
struct Prism {
  Polygon footprint;  // counter-clockwise
  double z0 = 0, z1 = 0;
  Colour colour;
  int group = 0;  // drawn together, in order (a robot's body, then its hat)
  double distance = 0;
};

Prism prism(Polygon footprint, double z0, double z1, Colour colour) {
  if (sim::signedArea(footprint) < 0) std::reverse(footprint.begin(), footprint.end());
  return {std::move(footprint), z0, z1, colour, 0, 0};
}

Polygon disk(Vec2 centre, double radius, int sides) {
  Polygon p;
  for (int i = 0; i < sides; ++i) {
    const double a = 2 * M_PI * i / sides;
    p.push_back({centre.x + radius * std::cos(a), centre.y + radius * std::sin(a)});
  }
  return p;
}

class Painter {
 public:
  Painter(const Calibration& c, cv::Mat& image) : c_(c), image_(image) {}

  // Clips a world polygon at the near plane and fills its projection.
  void fill(const std::vector<Eigen::Vector3d>& corners, const cv::Scalar& colour) {
    std::vector<Eigen::Vector3d> in;
    for (const auto& p : corners) in.push_back(c_.toCamera(p));
    std::vector<Eigen::Vector3d> clipped;
    for (std::size_t i = 0; i < in.size(); ++i) {
      const Eigen::Vector3d& a = in[i];
      const Eigen::Vector3d& b = in[(i + 1) % in.size()];
      const bool aIn = a.z() >= kNear, bIn = b.z() >= kNear;
      if (aIn) clipped.push_back(a);
      if (aIn != bIn) clipped.push_back(a + (b - a) * ((kNear - a.z()) / (b.z() - a.z())));
    }
    if (clipped.size() < 3) return;
    std::vector<cv::Point> pixels;
    for (const auto& p : clipped) {
      const double u = std::clamp(c_.fx * p.x() / p.z() + c_.cx, -1e5, 1e5);
      const double v = std::clamp(c_.fy * p.y() / p.z() + c_.cy, -1e5, 1e5);
      pixels.emplace_back(static_cast<int>(std::lround(u * (1 << kShift))),
                          static_cast<int>(std::lround(v * (1 << kShift))));
    }
    const cv::Point* points = pixels.data();
    const int count = static_cast<int>(pixels.size());
    cv::fillPoly(image_, &points, &count, 1, colour, cv::LINE_AA, kShift);
  }

  // `shade(point, factor)` gives the colour of a face lit as the floor is
  // at `point` (just in front of a side, at a top's centre).
  template <typename Shade>
  void prism(const Prism& p, Shade&& shade) {
    const Eigen::Vector3d eye = c_.position;
    const std::size_t n = p.footprint.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2 a = p.footprint[i], b = p.footprint[(i + 1) % n];
      const Vec2 outward{b.y - a.y, a.x - b.x};
      if (outward.dot(Vec2{eye.x() - a.x, eye.y() - a.y}) <= 0) continue;  // faces away
      const double length = outward.norm();
      const Vec2 front = (a + b) * 0.5 + (length > 0 ? outward * (0.05 / length) : Vec2{});
      fill({{a.x, a.y, p.z0}, {b.x, b.y, p.z0}, {b.x, b.y, p.z1}, {a.x, a.y, p.z1}},
           shade(front, 0.8));
    }
    if (eye.z() > p.z1) {
      std::vector<Eigen::Vector3d> lid;
      for (const Vec2 q : p.footprint) lid.emplace_back(q.x, q.y, p.z1);
      fill(lid, shade(sim::centroid(p.footprint), 1.0));
    }
  }

 private:
  const Calibration& c_;
  cv::Mat& image_;
};

cv::Scalar lit(Colour c, double gain) {
  return cv::Scalar(std::min(255.0, c.b * gain), std::min(255.0, c.g * gain),
                    std::min(255.0, c.r * gain));
}

// The floor: room colours times the light on the floor under each pixel.
void drawFloor(cv::Mat& image, const sim::World& world, const sim::LightModel& light,
               const sim::LightState& state, const CameraSpec& spec) {
  const Calibration& c = spec.calibration;
  image.setTo(cv::Scalar(45, 45, 45));
  Painter painter(c, image);
  for (const sim::Room& room : world.rooms) {
    std::vector<Eigen::Vector3d> corners;
    for (const Vec2 p : room.polygon) corners.emplace_back(p.x, p.y, 0);
    painter.fill(corners, cv::Scalar(room.colour.b, room.colour.g, room.colour.r));
  }
  // Gain (illuminance / exposure) on a grid of every 8th pixel, stretched.
  const int step = 8;
  const int columns = c.width / step + 2, rows = c.height / step + 2;
  cv::Mat gain(rows, columns, CV_32FC1);
  for (int r = 0; r < rows; ++r)
    for (int col = 0; col < columns; ++col) {
      const auto floor = c.intersectHeight(col * step, r * step, 0);
      const double lux =
          floor ? light.floorIlluminance(state, {floor->x(), floor->y()}) : world.ambientLux;
      gain.at<float>(r, col) = static_cast<float>(std::min(255.0 / 64, lux / spec.exposureLux));
    }
  // In 8-bit fixed point (gain x 64, so up to 4): cheap on whole images.
  cv::Mat gain8;
  gain.convertTo(gain8, CV_8UC1, 64.0);
  cv::Mat full;
  cv::resize(gain8, full, cv::Size(columns * step, rows * step), 0, 0, cv::INTER_LINEAR);
  full = full(cv::Rect(0, 0, c.width, c.height));
  cv::Mat gain3;
  cv::merge(std::vector<cv::Mat>{full, full, full}, gain3);
  cv::multiply(image, gain3, image, 1.0 / 64);
}

std::vector<Prism> solids(const sim::World& world, const sim::Scene& scene) {
  std::vector<Prism> all;
  for (const sim::Wall& wall : world.walls)
    for (std::size_t i = 1; i < wall.points.size(); ++i) {
      const Vec2 a = wall.points[i - 1], b = wall.points[i];
      const int pieces = std::max(1, static_cast<int>(std::ceil((b - a).norm() / kWallPiece)));
      for (int k = 0; k < pieces; ++k) {
        const Vec2 from = a + (b - a) * (static_cast<double>(k) / pieces);
        const Vec2 to = a + (b - a) * (static_cast<double>(k + 1) / pieces);
        // Only the pieces at the wall's ends reach past its end points.
        Polygon box = sim::thickSegment(from, to, wall.thickness);
        if (k > 0 || k < pieces - 1) {
          const Vec2 along = (b - a) * (1.0 / (b - a).norm());
          const Vec2 shrink = along * (wall.thickness / 2);
          if (k > 0) box[0] = box[0] + shrink, box[3] = box[3] + shrink;
          if (k < pieces - 1) box[1] = box[1] - shrink, box[2] = box[2] - shrink;
        }
        all.push_back(prism(box, 0, wall.height, wall.colour));
      }
    }
  for (const sim::Furniture& f : world.furniture)
    all.push_back(prism(f.polygon, 0, f.height, f.colour));
  for (std::size_t i = 0; i < world.lamps.size(); ++i) {
    const sim::Lamp& lamp = world.lamps[i];
    Prism pole = prism(disk(lamp.position, 0.03, 8), 0, lamp.height - 0.3, lamp.colour);
    Prism shade = prism(disk(lamp.position, 0.18, 16), lamp.height - 0.3, lamp.height, lamp.colour);
    pole.group = shade.group = 1000 + static_cast<int>(i);
    all.push_back(pole);
    all.push_back(shade);
  }
  for (std::size_t i = 0; i < world.objects.size(); ++i) {
    sim::Object o = world.objects[i];
    for (const auto& moved : scene.objects)
      if (moved.name == o.name) o.pose = moved.pose;
    all.push_back(prism(o.radius > 0 ? disk(o.pose.position(), o.radius, 16) : o.footprint(), 0,
                        o.height, o.colour));
  }
  for (const sim::Person& person : world.people) {
    double floor = 0;
    for (const sim::Furniture& f : world.furniture)
      if (sim::insidePolygon(f.polygon, person.pose.position())) floor = std::max(floor, f.height);
    // Lying on furniture (Johanna in bed), else standing.
    Polygon body = floor > 0
                       ? sim::box(person.pose.position(), {1.6, 0.45}, person.pose.theta + M_PI / 2)
                       : disk(person.pose.position(), 0.2, 12);
    all.push_back(prism(body, floor, floor + (floor > 0 ? 0.2 : 1.7), person.colour));
  }
  for (std::size_t i = 0; i < world.robots.size(); ++i) {
    const sim::Robot& robot = world.robots[i];
    sim::Pose2 pose = robot.start;
    bool present = false;
    for (const auto& r : scene.robots)
      if (r.name == robot.name) pose = r.pose, present = true;
    if (!present) continue;
    Prism body = prism(disk(pose.position(), robot.radius, 24), 0, robot.height, robot.colour);
    Prism hat = prism(disk(pose.position(), robot.hat.radius, 24), robot.height, robot.hatTop(),
                      robot.hat.colour);
    body.group = hat.group = 1 + static_cast<int>(i);
    all.push_back(body);
    all.push_back(hat);
  }
  return all;
}

// Gaussian sensor noise. Drawing 900,000 normal numbers per frame costs
// more than the rest of the rendering, so frames take a window of a pool of
// noise drawn once (per sigma), starting at a random offset per frame.
void addNoise(cv::Mat& image, double sigma, std::uint64_t seed) {
  static std::mutex mu;
  static std::map<double, cv::Mat> pools;
  const std::size_t need = image.total() * image.channels();
  cv::Mat pool;
  {
    std::lock_guard lock(mu);
    cv::Mat& p = pools[sigma];
    if (p.total() < 4 * need) {
      p.create(1, static_cast<int>(4 * need), CV_16SC1);
      cv::RNG rng(0x5eed);
      rng.fill(p, cv::RNG::NORMAL, 0, sigma);
    }
    pool = p;
  }
  std::mt19937_64 rng(seed);
  const std::size_t offset = rng() % (pool.total() - need);
  const cv::Mat noise(image.rows, image.cols, CV_16SC(image.channels()),
                      pool.ptr<std::int16_t>() + offset);
  cv::Mat noisy;
  image.convertTo(noisy, CV_16SC(image.channels()));
  noisy += noise;
  noisy.convertTo(image, image.type());
}

}  // namespace

cv::Mat renderView(const sim::World& world, const sim::LightModel& light, const sim::Scene& scene,
                   const CameraSpec& spec, std::uint64_t seed) {
  const Calibration& c = spec.calibration;
  const sim::LightState state = sim::lightStateOf(world, scene);
  cv::Mat image(c.height, c.width, CV_8UC3);
  drawFloor(image, world, light, state, spec);

  std::vector<Prism> all = solids(world, scene);
  const Vec2 eye{c.position.x(), c.position.y()};
  for (Prism& p : all) p.distance = (sim::centroid(p.footprint) - eye).norm();
  // A group is drawn at its first member's distance, members in order.
  std::vector<double> groupDistance(all.size(), 0);
  for (std::size_t i = 0; i < all.size(); ++i) {
    groupDistance[i] = all[i].distance;
    for (std::size_t j = 0; j < i; ++j)
      if (all[i].group != 0 && all[j].group == all[i].group) {
        groupDistance[i] = groupDistance[j];
        break;
      }
  }
  std::vector<std::size_t> order(all.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return groupDistance[a] > groupDistance[b];
  });
  Painter painter(c, image);
  for (std::size_t i : order) {
    const Prism& p = all[i];
    painter.prism(p, [&](Vec2 at, double factor) {
      const double gain = std::min(4.0, light.floorIlluminance(state, at) / spec.exposureLux);
      return lit(p.colour, gain * factor);
    });
  }

  if (spec.noise > 0) addNoise(image, spec.noise, seed);
  return image;
}

double meanBrightness(const cv::Mat& image) {
  if (image.empty()) return 0;
  cv::Mat grey;
  if (image.channels() == 3)
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else
    grey = image;
  return cv::mean(grey)[0];
}

}  // namespace peis::camera
