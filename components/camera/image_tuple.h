// Images as tuples (docs/components/sim-world.md, "Images and camera
// tuples"): `image/png`, or raw pixels with the mimetype
// `image/x-raw;format=bgr8;width=W;height=H` (or format=mono8), row-major,
// no padding. Encoding on the camera side, checked decoding on the reader's.
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace peis::camera {

enum class ImageFormat { Png, Raw };

struct EncodedImage {
  std::string mimetype;
  std::string data;
};

// `image` is BGR 8-bit (CV_8UC3) or grey (CV_8UC1).
EncodedImage encodeImage(const cv::Mat& image, ImageFormat format);

// A BGR image from a tuple's mimetype and data; empty with `why` set when
// the tuple is not an image this reader accepts (unknown mimetype, bad
// parameters, wrong length, undecodable PNG, larger than 8192 x 8192).
cv::Mat decodeImage(const std::string& mimetype, const std::string& data, std::string& why);

}  // namespace peis::camera
