// Calibration: pinhole projection and the camera YAML schema (calibration.h).
#include "camera/calibration.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "common/yaml_reader.h"

namespace peis::camera {

Eigen::Vector3d Calibration::toCamera(const Eigen::Vector3d& world) const {
  return rotation.transpose() * (world - position);
}

std::optional<Eigen::Vector2d> Calibration::project(const Eigen::Vector3d& world) const {
  const Eigen::Vector3d p = toCamera(world);
  if (p.z() <= 1e-9) return std::nullopt;
  return Eigen::Vector2d(fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy);
}

Eigen::Vector3d Calibration::rayDirection(double u, double v) const {
  const Eigen::Vector3d inCamera((u - cx) / fx, (v - cy) / fy, 1.0);
  return (rotation * inCamera).normalized();
}

std::optional<Eigen::Vector3d> Calibration::intersectHeight(double u, double v, double z) const {
  const Eigen::Vector3d d = rayDirection(u, v);
  if (std::abs(d.z()) < 1e-12) return std::nullopt;
  const double t = (z - position.z()) / d.z();
  if (t <= 0) return std::nullopt;
  return Eigen::Vector3d(position + t * d);
}

bool Calibration::inImage(const Eigen::Vector2d& pixel) const {
  return pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() < width - 0.5 &&
         pixel.y() < height - 0.5;
}

std::string Calibration::toYaml() const {
  char buffer[1024];
  std::snprintf(buffer, sizeof buffer,
                "name: %s\nwidth: %d\nheight: %d\nfx: %.6f\nfy: %.6f\ncx: %.6f\ncy: %.6f\n"
                "position: [%.6f, %.6f, %.6f]\n"
                "rotation: [%.9f, %.9f, %.9f, %.9f, %.9f, %.9f, %.9f, %.9f, %.9f]\n",
                name.c_str(), width, height, fx, fy, cx, cy, position.x(), position.y(),
                position.z(), rotation(0, 0), rotation(0, 1), rotation(0, 2), rotation(1, 0),
                rotation(1, 1), rotation(1, 2), rotation(2, 0), rotation(2, 1), rotation(2, 2));
  return buffer;
}

Eigen::Matrix3d lookAtRotation(const Eigen::Vector3d& position, const Eigen::Vector3d& target,
                               const Eigen::Vector3d& up) {
  const Eigen::Vector3d forward = target - position;
  if (forward.norm() < 1e-9) throw std::invalid_argument("look_at is the camera's position");
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d right = z.cross(up);
  if (right.norm() < 1e-6) throw std::invalid_argument("up is along the viewing direction");
  const Eigen::Vector3d x = right.normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = y;
  r.col(2) = z;
  return r;
}

namespace {

Eigen::Vector3d vector3(const components::YamlReader& reader, const YAML::Node& node,
                        const std::string& what) {
  const auto v = reader.numbers(node, 3, what);
  return {v[0], v[1], v[2]};
}

Eigen::Matrix3d rotationOf(const components::YamlReader& reader, const YAML::Node& entry) {
  const YAML::Node rotation = entry["rotation"];
  const YAML::Node lookAt = entry["look_at"];
  if (rotation && lookAt)
    reader.fail(rotation, "a camera has either rotation or look_at, not both");
  if (rotation) {
    const auto v = reader.numbers(rotation, 9, "camera rotation (row-major 3x3)");
    Eigen::Matrix3d r;
    r << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
    const double orthogonality = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
    if (orthogonality > 1e-4 || std::abs(r.determinant() - 1.0) > 1e-4)
      reader.fail(rotation, "camera rotation must be a rotation matrix (orthonormal, det 1)");
    return r;
  }
  if (!lookAt) reader.fail(entry, "a camera needs look_at or rotation");
  const Eigen::Vector3d position = vector3(reader, entry["position"], "camera position");
  const Eigen::Vector3d target = vector3(reader, lookAt, "camera look_at");
  Eigen::Vector3d up(0, 0, 1);
  if (entry["up"]) up = vector3(reader, entry["up"], "camera up");
  try {
    return lookAtRotation(position, target, up);
  } catch (const std::invalid_argument& e) {
    reader.fail(lookAt, std::string("camera look_at: ") + e.what() +
                            " (looking straight down? give up: [0, 1, 0])");
  }
}

}  // namespace

CameraSpec cameraFromYaml(const components::YamlReader& reader, const YAML::Node& entry) {
  reader.onlyKeys(entry,
                  {"name", "width", "height", "fx", "fy", "cx", "cy", "fov_deg", "position",
                   "look_at", "up", "rotation", "rate_hz", "noise", "exposure_lux"},
                  "a camera");
  CameraSpec spec;
  Calibration& c = spec.calibration;
  c.name = reader.name(reader.required(entry, "name", "a camera"), "camera name");
  c.width = static_cast<int>(reader.numberIn(entry, "width", 640, 16, 8192, "camera width"));
  c.height = static_cast<int>(reader.numberIn(entry, "height", 480, 16, 8192, "camera height"));
  if (entry["fov_deg"] && entry["fx"])
    reader.fail(entry["fov_deg"], "give fx or fov_deg, not both");
  if (entry["fov_deg"]) {
    const double fov = reader.numberIn(entry["fov_deg"], 1, 170, "camera fov_deg");
    c.fx = (c.width / 2.0) / std::tan(fov * M_PI / 360.0);
  } else {
    c.fx =
        reader.numberIn(reader.required(entry, "fx", "a camera (or fov_deg)"), 1, 1e6, "camera fx");
  }
  c.fy = reader.numberIn(entry, "fy", c.fx, 1, 1e6, "camera fy");
  c.cx = reader.numberIn(entry, "cx", (c.width - 1) / 2.0, -1e6, 1e6, "camera cx");
  c.cy = reader.numberIn(entry, "cy", (c.height - 1) / 2.0, -1e6, 1e6, "camera cy");
  c.position = vector3(reader, reader.required(entry, "position", "a camera"), "camera position");
  c.rotation = rotationOf(reader, entry);
  spec.rateHz = reader.numberIn(entry, "rate_hz", spec.rateHz, 0.1, 200, "camera rate_hz");
  spec.noise = reader.numberIn(entry, "noise", spec.noise, 0, 100, "camera noise");
  spec.exposureLux =
      reader.numberIn(entry, "exposure_lux", spec.exposureLux, 1, 1e6, "camera exposure_lux");
  return spec;
}

CameraSpec cameraFromFile(const std::string& path) {
  const components::YamlReader reader(path);
  const YAML::Node root = reader.parse(components::readTextFile(path, "camera file"));
  if (!root.IsMap()) reader.fail(root, "a camera file must be one camera mapping");
  return cameraFromYaml(reader, root);
}

Calibration calibrationFromYaml(std::string_view text, const std::string& origin) {
  const components::YamlReader reader(origin);
  const YAML::Node root = reader.parse(text);
  if (!root.IsMap()) reader.fail(root, "a calibration must be a camera mapping");
  return cameraFromYaml(reader, root).calibration;
}

}  // namespace peis::camera
