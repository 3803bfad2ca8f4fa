// Image tuples as pictures a browser shows. PNG, JPEG, GIF and WebP data
// pass as they are (with their mimetype); raw camera images
// (`image/x-raw;format=bgr8|mono8;width=W;height=H`, docs/components/camera.md)
// are converted to PNG, decoded by the camera model's checked decoder. PNG
// at compression level 1: a noisy camera frame hardly compresses, so the
// fastest level costs least for the same size. Pure (no I/O).
#pragma once

#include <optional>
#include <string>

namespace peis::view {

struct Picture {
  std::string mimetype;  // what the browser gets
  std::string data;
};

// True when the view can show tuples of this mimetype as a picture.
bool isPictureMimetype(const std::string& mimetype);

// The picture of a tuple's data, or nothing with `why` set (a mimetype that
// is not a picture, a raw image whose size does not match, ...).
std::optional<Picture> toPicture(const std::string& mimetype, const std::string& data,
                                 std::string& why);

}  // namespace peis::view
