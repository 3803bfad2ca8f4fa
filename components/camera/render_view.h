// renderView: what a simulated ceiling camera sees, drawn with OpenCV from
// its calibration and the world's state: floor (room colours), walls,
// furniture, lamps, objects, people, robots with their coloured hats, shaded
// by the light model under a fixed exposure, plus Gaussian sensor noise.
// Solids are convex prisms drawn far to near (painter's algorithm, walls cut
// into short pieces, back faces culled), which is exact enough for cameras
// that look down from the ceiling.
#pragma once

#include <opencv2/core.hpp>
#include <random>

#include "camera/calibration.h"
#include "sim/world/light_model.h"
#include "sim/world/scene.h"
#include "sim/world/world.h"

namespace peis::camera {

// A BGR 8-bit image of spec.calibration's size. `seed` drives the noise.
cv::Mat renderView(const sim::World& world, const sim::LightModel& light, const sim::Scene& scene,
                   const CameraSpec& spec, std::uint64_t seed);

// The mean grey level (0..255) of an image: the brightness a photo camera
// reports.
double meanBrightness(const cv::Mat& image);

}  // namespace peis::camera
