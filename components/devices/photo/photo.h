// The photo camera's pure parts: a photo of a region lit with a given
// illuminance (the light model's lux at the region, through a fixed
// exposure, with sensor noise), and the brightness measured from the photo's
// pixels (mean grey level 0..255) — measured from the image, as a real
// camera's auto-check would, not copied from the lux.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace peis::devices {

struct PhotoSettings {
  int width = 320, height = 240;
  double fullExposureLux = 300;  // lux at which the region shows its full colour
  double noise = 3.0;            // grey levels of sensor noise (standard deviation)
};

// A BGR photo of a region of colour `rgb` lit by `lux`.
cv::Mat takePhoto(const std::array<int, 3>& rgb, double lux, const PhotoSettings& settings,
                  std::uint32_t seed);
// Mean grey level of a BGR image, 0..255.
double measureBrightness(const cv::Mat& bgr);
// PNG bytes of an image.
std::string encodePng(const cv::Mat& image);

}  // namespace peis::devices
