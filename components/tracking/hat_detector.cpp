// Colour segmentation of hats (hat_detector.h).
#include "tracking/hat_detector.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace peis::tracking {

HatDetector::HatDetector(std::vector<Target> targets, DetectorSettings settings)
    : targets_(std::move(targets)), settings_(settings), hueToTarget_(180, -1) {
  for (int hue = 0; hue < 180; ++hue) {
    double best = settings_.hueTolerance + 1e-9;
    for (std::size_t t = 0; t < targets_.size(); ++t) {
      double distance = std::abs(hue - targets_[t].hue);
      distance = std::min(distance, 180 - distance);  // hue is circular
      if (distance <= best) {
        best = distance;
        hueToTarget_[hue] = static_cast<int>(t);
      }
    }
  }
}

std::vector<Detection> HatDetector::detect(const cv::Mat& bgr) {
  std::vector<Detection> found;
  if (bgr.empty() || bgr.type() != CV_8UC3 || targets_.empty()) return found;
  cv::cvtColor(bgr, hsv_, cv::COLOR_BGR2HSV);
  labels_.create(bgr.size(), CV_8UC1);
  // Per target, the bounding box of its pixels: the blob search looks there only.
  std::vector<cv::Point> lo(targets_.size(), {bgr.cols, bgr.rows}), hi(targets_.size(), {-1, -1});
  const int minS = settings_.minSaturation, minV = settings_.minValue;
  for (int y = 0; y < hsv_.rows; ++y) {
    const cv::Vec3b* in = hsv_.ptr<cv::Vec3b>(y);
    std::uint8_t* out = labels_.ptr<std::uint8_t>(y);
    for (int x = 0; x < hsv_.cols; ++x) {
      const cv::Vec3b p = in[x];
      int target = -1;
      if (p[1] >= minS && p[2] >= minV) target = hueToTarget_[std::min<int>(p[0], 179)];
      out[x] = static_cast<std::uint8_t>(target + 1);
      if (target >= 0) {
        cv::Point& l = lo[static_cast<std::size_t>(target)];
        cv::Point& h = hi[static_cast<std::size_t>(target)];
        l.x = std::min(l.x, x), l.y = std::min(l.y, y);
        h.x = std::max(h.x, x), h.y = std::max(h.y, y);
      }
    }
  }
  for (std::size_t t = 0; t < targets_.size(); ++t) {
    if (hi[t].x < 0) continue;
    const cv::Rect box(lo[t], hi[t] + cv::Point(1, 1));
    const cv::Mat mask = labels_(box) == static_cast<int>(t + 1);
    const int count =
        cv::connectedComponentsWithStats(mask, components_, stats_, centroids_, 8, CV_32S);
    int best = -1, bestArea = settings_.minArea - 1;
    for (int c = 1; c < count; ++c) {
      const int area = stats_.at<int>(c, cv::CC_STAT_AREA);
      const int left = box.x + stats_.at<int>(c, cv::CC_STAT_LEFT);
      const int top = box.y + stats_.at<int>(c, cv::CC_STAT_TOP);
      const int right = left + stats_.at<int>(c, cv::CC_STAT_WIDTH);
      const int bottom = top + stats_.at<int>(c, cv::CC_STAT_HEIGHT);
      const bool cut = left == 0 || top == 0 || right == bgr.cols || bottom == bgr.rows;
      if (!cut && area > bestArea) best = c, bestArea = area;
    }
    if (best < 0) continue;
    found.push_back({t, box.x + centroids_.at<double>(best, 0),
                     box.y + centroids_.at<double>(best, 1), bestArea});
  }
  return found;
}

}  // namespace peis::tracking
