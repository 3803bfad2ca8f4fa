// Triangulation of hats (triangulation.h).
#include "tracking/triangulation.h"

#include <Eigen/Dense>
#include <cmath>

namespace peis::tracking {

std::optional<Fix> intersectHeight(const Sighting& s, double height, const NoiseModel& noise) {
  if (s.camera == nullptr) return std::nullopt;
  const auto at = [&](double u, double v, double h) { return s.camera->intersectHeight(u, v, h); };
  const auto point = at(s.u, s.v, height);
  if (!point) return std::nullopt;
  // Covariance by propagating pixel and height noise through the
  // intersection (central differences).
  Eigen::Matrix<double, 2, 3> jacobian;
  const double steps[3] = {0.5, 0.5, 0.01};
  for (int k = 0; k < 3; ++k) {
    double plus[3] = {s.u, s.v, height}, minus[3] = {s.u, s.v, height};
    plus[k] += steps[k];
    minus[k] -= steps[k];
    const auto a = at(plus[0], plus[1], plus[2]), b = at(minus[0], minus[1], minus[2]);
    if (!a || !b) return std::nullopt;
    jacobian.col(k) = (*a - *b).head<2>() / (2 * steps[k]);
  }
  const Eigen::Vector3d variances(noise.pixelSigma * noise.pixelSigma,
                                  noise.pixelSigma * noise.pixelSigma,
                                  noise.heightSigma * noise.heightSigma);
  Fix fix;
  fix.point = *point;
  fix.covariance = jacobian * variances.asDiagonal() * jacobian.transpose();
  fix.cameras = 1;
  return fix;
}

namespace {

struct Ray {
  Eigen::Vector3d origin, direction;
  double focal;
};

// Weighted least squares over rays plus the height prior; nullopt if singular.
std::optional<Fix> solve(const std::vector<Ray>& rays, double height, const NoiseModel& noise) {
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d up(0, 0, 1);
  const double heightWeight = 1.0 / (noise.heightSigma * noise.heightSigma);
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Matrix3d normal;
  // First unweighted (each ray 1 m away), then weighted by the distances found.
  for (int pass = 0; pass < 2; ++pass) {
    normal = heightWeight * up * up.transpose() * (pass == 0 ? 1e-6 : 1.0);
    Eigen::Vector3d rhs = normal * up * height;
    for (const Ray& ray : rays) {
      const Eigen::Matrix3d across = identity - ray.direction * ray.direction.transpose();
      double distance = 1.0;
      if (pass == 1) distance = std::max(0.1, ray.direction.dot(point - ray.origin));
      const double sigma = noise.pixelSigma * distance / ray.focal;
      const double weight = 1.0 / (sigma * sigma);
      normal += weight * across;
      rhs += weight * across * ray.origin;
    }
    Eigen::FullPivLU<Eigen::Matrix3d> lu(normal);
    if (!lu.isInvertible() || lu.rcond() < 1e-12) return std::nullopt;
    point = lu.solve(rhs);
  }
  Fix fix;
  fix.point = point;
  fix.covariance = normal.inverse().topLeftCorner<2, 2>();
  fix.cameras = static_cast<int>(rays.size());
  return fix;
}

}  // namespace

std::optional<Fix> triangulate(const std::vector<Sighting>& sightings, double height,
                               const NoiseModel& noise) {
  std::vector<Ray> rays;
  for (const Sighting& s : sightings)
    if (s.camera != nullptr)
      rays.push_back({s.camera->position, s.camera->rayDirection(s.u, s.v),
                      (s.camera->fx + s.camera->fy) / 2});
  if (rays.empty()) return std::nullopt;
  if (rays.size() == 1) {
    for (const Sighting& s : sightings)
      if (s.camera != nullptr) return intersectHeight(s, height, noise);
  }
  // Consensus: the pair of rays whose solution most other rays agree with
  // (then the smallest residual); a solution must lie in front of its
  // cameras, at the hat's height, within the gate of each ray it keeps.
  const auto agreeing = [&](const Fix& fix) {
    std::vector<Ray> inliers;
    double residuals = 0;
    for (const Ray& ray : rays) {
      const Eigen::Vector3d offset = fix.point - ray.origin;
      const double along = ray.direction.dot(offset);
      const double residual = (offset - along * ray.direction).norm();
      if (along > 0 && residual <= noise.gate) {
        inliers.push_back(ray);
        residuals += residual;
      }
    }
    return std::make_pair(inliers, residuals);
  };
  std::vector<Ray> best;
  double bestResiduals = INFINITY;
  for (std::size_t i = 0; i < rays.size(); ++i)
    for (std::size_t j = i + 1; j < rays.size(); ++j) {
      const auto fix = solve({rays[i], rays[j]}, height, noise);
      if (!fix || std::abs(fix->point.z() - height) > noise.gate) continue;
      auto [inliers, residuals] = agreeing(*fix);
      if (inliers.size() < 2) continue;
      if (inliers.size() > best.size() ||
          (inliers.size() == best.size() && residuals < bestResiduals)) {
        best = std::move(inliers);
        bestResiduals = residuals;
      }
    }
  if (best.size() < 2) return std::nullopt;  // the cameras disagree: no way to tell who is right
  return solve(best, height, noise);
}

}  // namespace peis::tracking
