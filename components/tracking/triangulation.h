// Triangulation: a target's position from the rays of the cameras that see
// it (Eigen). With two or more rays, the weighted least-squares point
// nearest to all rays, each ray weighted by its lateral uncertainty (pixel
// noise times distance over focal length), with the hat's known height as a
// weak extra measurement; with one ray, its intersection with the plane of
// the hat's height. Both give a covariance of x and y from the same noise
// model, so a single-camera fix carries a larger covariance.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "camera/calibration.h"

namespace peis::tracking {

// A detection seen through a camera.
struct Sighting {
  const camera::Calibration* camera = nullptr;
  double u = 0, v = 0;
};

struct NoiseModel {
  double pixelSigma = 1.0;    // centroid uncertainty, pixels
  double heightSigma = 0.03;  // uncertainty of the hat's height, metres
  double gate = 0.15;         // a ray farther than this from the solution is dropped, metres
};

struct Fix {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  // of x, y (m²)
  int cameras = 0;                                       // rays used
};

// Ground-plane (hat-plane) intersection of one sighting.
std::optional<Fix> intersectHeight(const Sighting& sighting, double height,
                                   const NoiseModel& noise);
// Any number of sightings: none gives nothing, one the height-plane fix;
// with two or more, the largest set of rays that agree within the gate (found
// from every pair) is solved together; if no two agree, nothing.
std::optional<Fix> triangulate(const std::vector<Sighting>& sightings, double height,
                               const NoiseModel& noise);

}  // namespace peis::tracking
