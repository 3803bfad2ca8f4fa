// A photo of a lit region and its measured brightness (see photo.h).
#include "photo.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace peis::devices {

cv::Mat takePhoto(const std::array<int, 3>& rgb, double lux, const PhotoSettings& s,
                  std::uint32_t seed) {
  cv::Mat image(s.height, s.width, CV_8UC3);
  const double gain = std::clamp(lux / s.fullExposureLux, 0.0, 4.0);
  cv::RNG rng(seed);
  const double cx = s.width / 2.0, cy = s.height / 2.0, r2 = cx * cx + cy * cy;
  for (int y = 0; y < s.height; ++y) {
    auto* row = image.ptr<cv::Vec3b>(y);
    for (int x = 0; x < s.width; ++x) {
      // A little vignetting, as a cheap lens gives.
      const double vignette = 1.0 - 0.25 * ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2;
      for (int c = 0; c < 3; ++c) {
        const double value = rgb[2 - c] * gain * vignette + rng.gaussian(s.noise);
        row[x][c] = cv::saturate_cast<std::uint8_t>(value);
      }
    }
  }
  return image;
}

double measureBrightness(const cv::Mat& bgr) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw std::invalid_argument("not an 8-bit BGR image");
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  return cv::mean(grey)[0];
}

std::string encodePng(const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  cv::imencode(".png", image, bytes);
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace peis::devices
