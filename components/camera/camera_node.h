// CameraNode: one simulated ceiling camera as a PEIS (peis-camera). It
// reads the home's geometry (physics.world) and state (physics.scene) from
// the world PEIS — the physics channel that only simulated sensors read —
// renders what its calibration sees on a worker thread, and publishes
// `image` (stamped with the scene's simulated time) and `calibration`
// (docs/components/camera.md).
#pragma once

#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "camera/calibration.h"
#include "camera/image_tuple.h"
#include "peis/component.h"
#include "peis/kernel.h"
#include "sim/world/light_model.h"
#include "sim/world/world.h"

namespace peis::camera {

struct CameraConfig {
  std::string camera;                     // a camera of the world file, or
  std::optional<CameraSpec> calibration;  // from --calibration FILE (wins)
  std::string world = "world";            // the world PEIS, name or id
  std::optional<double> rateHz, noise;    // override the camera's own
  ImageFormat format = ImageFormat::Raw;
  std::uint64_t seed = 1;
  Options peis;
};

class CameraNode {
 public:
  explicit CameraNode(CameraConfig config);
  ~CameraNode();
  Kernel& kernel() { return *kernel_; }
  std::string run();
  std::uint64_t framesPublished() const;

 private:
  void findWorld();
  void onWorld(const Tuple& t);
  void onScene(const Tuple& t);
  void renderLoop();

  CameraConfig config_;
  std::unique_ptr<Kernel> kernel_;
  std::unique_ptr<Component> component_;
  std::optional<TimerHandle> findTimer_;
  CallbackHandle worldCallback_ = 0;

  mutable std::mutex mu_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::shared_ptr<const sim::World> world_;
  std::shared_ptr<const sim::LightModel> light_;
  std::optional<CameraSpec> spec_;
  std::optional<Tuple> pendingScene_;
  std::int64_t lastSlot_ = -1;  // the last multiple of 1/rate rendered
  std::uint64_t frames_ = 0;
  std::thread worker_;
};

}  // namespace peis::camera
