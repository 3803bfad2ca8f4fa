// Inflation of the occupancy grid by the robot's radius, with a linear-time
// exact Euclidean distance transform.
#include "costmap.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace peis::nav {

namespace {

// One dimension of the squared distance transform (Felzenszwalb &
// Huttenlocher, "Distance Transforms of Sampled Functions", 2012): the lower
// envelope of the parabolas rooted at (q, f[q]). Doubles: the squared
// distances of a 20,000-cell side do not fit a float's mantissa.
void transform1d(const double* f, int n, double* d, int* v, double* z) {
  auto intersection = [&](int q, int p) {
    return ((f[q] + double(q) * q) - (f[p] + double(p) * p)) / (2.0 * (q - p));
  };
  int k = 0;
  v[0] = 0;
  z[0] = -std::numeric_limits<double>::infinity();
  z[1] = std::numeric_limits<double>::infinity();
  for (int q = 1; q < n; ++q) {
    double s = intersection(q, v[k]);
    while (s <= z[k]) {
      --k;
      s = intersection(q, v[k]);
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = std::numeric_limits<double>::infinity();
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double dq = double(q - v[k]);
    d[q] = dq * dq + f[v[k]];
  }
}

}  // namespace

std::vector<float> distanceTransform(const OccupancyGrid& grid) {
  const int w = grid.width(), h = grid.height();
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  // Larger than any squared distance inside the grid, small enough to stay exact.
  const double far = double(w) * w + double(h) * h + 1.0;
  std::vector<double> squared(n);
  for (std::size_t i = 0; i < n; ++i) squared[i] = grid.cells()[i] ? 0.0 : far;
  const int longest = std::max(w, h);
  std::vector<double> f(longest), d(longest), z(longest + 1);
  std::vector<int> v(longest);
  for (int x = 0; x < w; ++x) {  // columns
    for (int y = 0; y < h; ++y) f[y] = squared[static_cast<std::size_t>(y) * w + x];
    transform1d(f.data(), h, d.data(), v.data(), z.data());
    for (int y = 0; y < h; ++y) squared[static_cast<std::size_t>(y) * w + x] = d[y];
  }
  std::vector<float> out(n);
  for (int y = 0; y < h; ++y) {  // rows
    const std::size_t row = static_cast<std::size_t>(y) * w;
    std::copy(squared.begin() + row, squared.begin() + row + w, f.begin());
    transform1d(f.data(), w, d.data(), v.data(), z.data());
    for (int x = 0; x < w; ++x) out[row + x] = static_cast<float>(std::sqrt(d[x]));
  }
  return out;
}

Costmap::Costmap(const OccupancyGrid& grid, const InflationOptions& options)
    : grid_(grid), options_(options) {
  clearance_ = distanceTransform(grid_);
  const float resolution = static_cast<float>(grid_.info().resolution);
  for (float& c : clearance_) c *= resolution;
  lethal_.assign(clearance_.size(), 0);
  factor_.assign(clearance_.size(), 1.0f);
  for (std::size_t i = 0; i < clearance_.size(); ++i) classify(i);
}

void Costmap::classify(std::size_t i) {
  const double lethalBelow = options_.robotRadius + options_.safetyMargin;
  const double c = clearance_[i];
  lethal_[i] = c < lethalBelow ? 1 : 0;
  const double into = lethalBelow + options_.comfortDistance - c;
  factor_[i] =
      into > 0 && options_.comfortDistance > 0
          ? static_cast<float>(1.0 + options_.comfortWeight * into / options_.comfortDistance)
          : 1.0f;
}

void Costmap::addObstacle(Point2 p, double radius) {
  const double res = grid_.info().resolution;
  const Cell centre = grid_.cellOf(p);
  const int r = static_cast<int>(std::ceil(radius / res));
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const Cell c{centre.x + dx, centre.y + dy};
      if (grid_.inside(c) && std::hypot(dx, dy) * res <= radius) grid_.setOccupied(c, true);
    }
  const double reach =
      radius + options_.robotRadius + options_.safetyMargin + options_.comfortDistance;
  inflateAround(centre, static_cast<int>(std::ceil(reach / res)) + 1);
}

void Costmap::inflateAround(Cell centre, int reach) {
  // Local update: every cell within `reach` gets its clearance to the nearest
  // occupied cell within 2 * reach (enough, since an obstacle further away
  // cannot be nearer than the new one at the centre).
  const double res = grid_.info().resolution;
  for (int dy = -reach; dy <= reach; ++dy)
    for (int dx = -reach; dx <= reach; ++dx) {
      const Cell c{centre.x + dx, centre.y + dy};
      if (!grid_.inside(c)) continue;
      float best = clearance_[grid_.index(c)];
      for (int oy = -reach; oy <= reach; ++oy)
        for (int ox = -reach; ox <= reach; ++ox) {
          const Cell o{centre.x + ox, centre.y + oy};
          if (!grid_.inside(o) || !grid_.occupied(o)) continue;
          best = std::min(best, static_cast<float>(std::hypot(o.x - c.x, o.y - c.y) * res));
        }
      clearance_[grid_.index(c)] = best;
      classify(grid_.index(c));
    }
}

}  // namespace peis::nav
