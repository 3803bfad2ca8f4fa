// Calibration: a pinhole camera's intrinsics (fx, fy, cx, cy, image size)
// and pose in the home (centre and rotation), with the projections the
// ceiling-camera renderer and the tracker share. Pixel coordinates follow
// OpenCV: u to the right, v down, the centre of pixel (i, j) at (i, j). The
// camera frame: x right, y down, z forward (the viewing direction).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>

namespace YAML {
class Node;
}

namespace peis::components {
class YamlReader;
}

namespace peis::camera {

struct Calibration {
  std::string name;
  int width = 640;
  int height = 480;
  double fx = 400, fy = 400, cx = 319.5, cy = 239.5;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // the optical centre, world frame
  Eigen::Matrix3d rotation =
      Eigen::Matrix3d::Identity();  // camera to world (columns: x, y, z axes)

  Eigen::Vector3d toCamera(const Eigen::Vector3d& world) const;
  // The pixel showing `world`; nullopt when it is behind the camera (or on
  // its plane). The pixel may lie outside the image.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& world) const;
  // The unit direction, world frame, of the ray through pixel (u, v).
  Eigen::Vector3d rayDirection(double u, double v) const;
  // Where the ray through (u, v) meets the horizontal plane at height z;
  // nullopt when it does not (parallel, or the plane is behind).
  std::optional<Eigen::Vector3d> intersectHeight(double u, double v, double z) const;
  bool inImage(const Eigen::Vector2d& pixel) const;

  // The calibration tuple's YAML (see docs/components/camera.md).
  std::string toYaml() const;
};

// A camera entry of a world file or a camera file: the calibration and how
// the simulated camera renders.
struct CameraSpec {
  Calibration calibration;
  double rateHz = 10;        // images per second of simulated time
  double noise = 2.0;        // Gaussian sensor noise, standard deviation in grey levels
  double exposureLux = 400;  // illuminance at which a white surface reads 255
};

// Rotation (camera to world) of a camera at `position` looking at `target`,
// with the image's "up" towards `up` (the image's -y axis). Throws
// std::invalid_argument when target = position or up is along the view.
Eigen::Matrix3d lookAtRotation(const Eigen::Vector3d& position, const Eigen::Vector3d& target,
                               const Eigen::Vector3d& up);

// One camera mapping (keys in docs/components/camera.md); errors name
// file:line. Used by the world file reader and by cameraFromFile.
CameraSpec cameraFromYaml(const components::YamlReader& reader, const YAML::Node& entry);
// A camera file: one camera mapping at top level.
CameraSpec cameraFromFile(const std::string& path);
// A calibration tuple's text (toYaml's output, or any camera mapping).
Calibration calibrationFromYaml(std::string_view text, const std::string& origin);

}  // namespace peis::camera
