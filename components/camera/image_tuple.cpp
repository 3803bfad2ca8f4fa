// Images as tuples (image_tuple.h).
#include "camera/image_tuple.h"

#include <charconv>
#include <cstdint>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace peis::camera {
namespace {

constexpr int kMaxSide = 8192;

// "image/x-raw;format=bgr8;width=640;height=480" -> {format: bgr8, ...}.
bool rawParameters(const std::string& mimetype, std::map<std::string, std::string>& out) {
  const std::string prefix = "image/x-raw;";
  if (mimetype.compare(0, prefix.size(), prefix) != 0) return false;
  std::size_t at = prefix.size();
  while (at < mimetype.size()) {
    const std::size_t end = std::min(mimetype.find(';', at), mimetype.size());
    const std::string item = mimetype.substr(at, end - at);
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0) return false;
    out[item.substr(0, eq)] = item.substr(eq + 1);
    at = end + 1;
  }
  return true;
}

int side(const std::string& text) {
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value <= 0 || value > kMaxSide)
    return 0;
  return value;
}

// Width and height from a PNG's IHDR chunk, read before decoding so a
// small file cannot make the decoder allocate a huge image.
bool pngSize(const std::string& data, std::uint32_t& width, std::uint32_t& height) {
  static const char signature[8] = {'\x89', 'P', 'N', 'G', '\r', '\n', '\x1a', '\n'};
  if (data.size() < 24 || data.compare(0, 8, std::string(signature, 8)) != 0 ||
      data.compare(12, 4, "IHDR") != 0)
    return false;
  const auto big = [&](std::size_t at) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(data[at])) << 24 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(data[at + 1])) << 16 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(data[at + 2])) << 8 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(data[at + 3]));
  };
  width = big(16);
  height = big(20);
  return true;
}

}  // namespace

EncodedImage encodeImage(const cv::Mat& image, ImageFormat format) {
  EncodedImage out;
  if (format == ImageFormat::Png) {
    std::vector<unsigned char> png;
    // Level 1: noisy camera images hardly compress; spend little time trying.
    cv::imencode(".png", image, png, {cv::IMWRITE_PNG_COMPRESSION, 1});
    out.mimetype = "image/png";
    out.data.assign(png.begin(), png.end());
    return out;
  }
  const bool grey = image.channels() == 1;
  out.mimetype = std::string("image/x-raw;format=") + (grey ? "mono8" : "bgr8") +
                 ";width=" + std::to_string(image.cols) + ";height=" + std::to_string(image.rows);
  const cv::Mat packed = image.isContinuous() ? image : image.clone();
  out.data.assign(reinterpret_cast<const char*>(packed.data), packed.total() * packed.elemSize());
  return out;
}

cv::Mat decodeImage(const std::string& mimetype, const std::string& data, std::string& why) {
  if (mimetype == "image/png") {
    std::uint32_t width = 0, height = 0;
    if (!pngSize(data, width, height)) {
      why = "image/png data that is not a PNG image";
      return {};
    }
    if (width == 0 || height == 0 || width > kMaxSide || height > kMaxSide) {
      why = "a PNG image of " + std::to_string(width) + " x " + std::to_string(height) +
            " (at most 8192 x 8192)";
      return {};
    }
    const cv::Mat bytes(1, static_cast<int>(data.size()), CV_8UC1, const_cast<char*>(data.data()));
    cv::Mat image = cv::imdecode(bytes, cv::IMREAD_COLOR);
    if (image.empty()) why = "image/png data that is not a PNG image";
    return image;
  }
  std::map<std::string, std::string> parameters;
  if (!rawParameters(mimetype, parameters)) {
    why = "mimetype '" + mimetype.substr(0, 80) + "' is not an image this reader accepts";
    return {};
  }
  const int width = side(parameters["width"]), height = side(parameters["height"]);
  const std::string& format = parameters["format"];
  const int channels = format == "bgr8" ? 3 : format == "mono8" ? 1 : 0;
  if (width == 0 || height == 0 || channels == 0) {
    why = "raw image mimetype '" + mimetype.substr(0, 80) +
          "' needs format=bgr8|mono8 and width, height in 1..8192";
    return {};
  }
  const std::size_t expected = static_cast<std::size_t>(width) * height * channels;
  if (data.size() != expected) {
    why = "raw image of " + std::to_string(width) + "x" + std::to_string(height) + " " + format +
          " must be " + std::to_string(expected) + " bytes, not " + std::to_string(data.size());
    return {};
  }
  const cv::Mat view(height, width, channels == 3 ? CV_8UC3 : CV_8UC1,
                     const_cast<char*>(data.data()));
  cv::Mat image;
  if (channels == 3)
    image = view.clone();
  else
    cv::cvtColor(view, image, cv::COLOR_GRAY2BGR);
  return image;
}

}  // namespace peis::camera
