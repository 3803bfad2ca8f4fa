// HatDetector: finds each target's coloured hat in a BGR image by colour
// segmentation. One pass turns every saturated, bright pixel whose hue is
// within the tolerance of a target's hue into that target's label; each
// target's largest connected blob of at least `minArea` pixels that does not
// touch the image border (a hat cut by the border has a biased centre) is
// its detection, located at the blob's centroid.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "tracking/targets.h"

namespace peis::tracking {

struct DetectorSettings {
  int minSaturation = 100;  // 0..255
  int minValue = 25;        // 0..255
  double hueTolerance = 8;  // OpenCV hue units (2 degrees each)
  int minArea = 12;         // pixels
};

struct Detection {
  std::size_t target = 0;  // index into the targets
  double u = 0, v = 0;     // centroid, pixels
  int area = 0;            // pixels
};

class HatDetector {
 public:
  HatDetector(std::vector<Target> targets, DetectorSettings settings = {});
  // At most one detection per target, in target order.
  std::vector<Detection> detect(const cv::Mat& bgr);
  const std::vector<Target>& targets() const { return targets_; }

 private:
  std::vector<Target> targets_;
  DetectorSettings settings_;
  std::vector<int> hueToTarget_;  // 180 entries: target index or -1
  cv::Mat hsv_, labels_, components_, stats_, centroids_;
};

}  // namespace peis::tracking
