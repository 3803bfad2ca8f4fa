// Image tuples as pictures a browser shows (image_convert.h).
#include "view/image_convert.h"

#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "camera/image_tuple.h"

namespace peis::view {
namespace {

bool passesAsIs(const std::string& mimetype) {
  return mimetype == "image/png" || mimetype == "image/jpeg" || mimetype == "image/gif" ||
         mimetype == "image/webp";
}

bool isRaw(const std::string& mimetype) { return mimetype.rfind("image/x-raw;", 0) == 0; }

}  // namespace

bool isPictureMimetype(const std::string& mimetype) {
  return passesAsIs(mimetype) || isRaw(mimetype);
}

std::optional<Picture> toPicture(const std::string& mimetype, const std::string& data,
                                 std::string& why) {
  if (passesAsIs(mimetype)) return Picture{mimetype, data};
  if (!isRaw(mimetype)) {
    why = "mimetype '" + mimetype +
          "' is not a picture this view shows (image/png, image/jpeg, image/gif, image/webp, "
          "image/x-raw;format=bgr8|mono8;width=W;height=H)";
    return std::nullopt;
  }
  const cv::Mat image = camera::decodeImage(mimetype, data, why);
  if (image.empty()) return std::nullopt;
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", image, png, {cv::IMWRITE_PNG_COMPRESSION, 1})) {
    why = "could not encode the image as PNG";
    return std::nullopt;
  }
  return Picture{"image/png", std::string(png.begin(), png.end())};
}

}  // namespace peis::view
