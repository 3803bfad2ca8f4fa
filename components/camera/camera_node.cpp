// A simulated ceiling camera's PEIS (camera_node.h).
#include "camera_node.h"

#include <cmath>
#include <iostream>

#include "camera/render_view.h"
#include "camera_descriptor.h"
#include "peis/descriptor.h"
#include "peis/error.h"
#include "sim/world/scene.h"

namespace peis::camera {

CameraNode::CameraNode(CameraConfig config) : config_(std::move(config)) {
  kernel_ = std::make_unique<Kernel>(config_.peis);
  component_ = std::make_unique<Component>(*kernel_, "camera",
                                           Descriptor::fromYaml(kCameraDescriptor, "camera.yaml"));
  if (config_.calibration) {
    spec_ = config_.calibration;
    WriteOptions yaml;
    yaml.mimetype = "application/yaml";
    kernel_->set("calibration", spec_->calibration.toYaml(), yaml);
  }
  // The physics channel as an input: waiting (cause "physics") until the
  // world's scene arrives, and again when it stops coming.
  component_->input("physics", std::chrono::seconds(3), [this](const Tuple& t) { onScene(t); });
  component_->start();
  worker_ = std::thread([this] { renderLoop(); });
  findTimer_ = kernel_->every(std::chrono::milliseconds(200), [this] { findWorld(); });
}

CameraNode::~CameraNode() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  if (findTimer_) kernel_->cancelTimer(*findTimer_);
  if (worldCallback_ != 0) kernel_->removeCallback(worldCallback_);
  component_.reset();
  kernel_.reset();
}

std::uint64_t CameraNode::framesPublished() const {
  std::lock_guard lock(mu_);
  return frames_;
}

void CameraNode::findWorld() {
  PeisId world = 0;
  try {
    world = kernel_->resolveOwner(config_.world);
  } catch (const Error&) {
    return;  // not known yet
  }
  kernel_->cancelTimer(*findTimer_);
  findTimer_.reset();
  kernel_->subscribe(Pattern::exact(world, "physics.world"));
  worldCallback_ = kernel_->onChange(Pattern::exact(world, "physics.world"),
                                     [this](const Tuple& t) { onWorld(t); });
  if (auto known = kernel_->get(world, "physics.world")) onWorld(*known);
  kernel_->setMeta(metaInputKey("physics"), world, "physics.scene");
}

void CameraNode::onWorld(const Tuple& t) {
  try {
    auto world = std::make_shared<sim::World>(sim::parseWorld(t.data, t.fullName()));
    std::optional<CameraSpec> spec = config_.calibration;
    if (!spec) {
      const CameraSpec* named = world->camera(config_.camera);
      if (named == nullptr) {
        component_->fail("the world has no camera '" + config_.camera + "'");
        std::cerr << "peis-camera: the world " << t.fullName() << " has no camera '"
                  << config_.camera << "'\n";
        return;
      }
      spec = *named;
    }
    if (config_.rateHz) spec->rateHz = *config_.rateHz;
    if (config_.noise) spec->noise = *config_.noise;
    auto light = std::make_shared<sim::LightModel>(*world);
    {
      std::lock_guard lock(mu_);
      world_ = world;
      light_ = light;
      spec_ = spec;
    }
    WriteOptions yaml;
    yaml.mimetype = "application/yaml";
    kernel_->set("calibration", spec->calibration.toYaml(), yaml);
  } catch (const Error& e) {
    component_->fail(std::string("the world's physics.world is broken: ") + e.what());
    std::cerr << "peis-camera: " << e.what() << "\n";
  }
}

void CameraNode::onScene(const Tuple& t) {
  {
    std::lock_guard lock(mu_);
    pendingScene_ = t;
  }
  wake_.notify_one();
}

void CameraNode::renderLoop() {
  std::unique_lock lock(mu_);
  while (true) {
    wake_.wait(lock, [this] { return stop_ || (pendingScene_ && world_); });
    if (stop_) return;
    const Tuple tuple = *pendingScene_;
    pendingScene_.reset();
    const auto world = world_;
    const auto light = light_;
    const CameraSpec spec = *spec_;
    lock.unlock();
    std::optional<EncodedImage> image;
    double time = 0;
    try {
      const sim::Scene scene = sim::parseScene(tuple.data);
      time = scene.time;
      bool due = false;
      {
        std::lock_guard again(mu_);
        // Images at the camera's rate of simulated time, on a grid of
        // multiples of 1/rate, so cameras of one rate show the same moments.
        const auto slot = static_cast<std::int64_t>(std::floor(time * spec.rateHz + 1e-6));
        due = slot != lastSlot_;
        if (due) lastSlot_ = slot;
      }
      if (due)
        image = encodeImage(
            renderView(*world, *light, scene, spec,
                       config_.seed * 1000003u + static_cast<std::uint64_t>(time * 1000)),
            config_.format);
    } catch (const std::exception& e) {
      std::cerr << "peis-camera: ignored a scene: " << e.what() << "\n";
    }
    if (image) {
      WriteOptions options;
      options.mimetype = image->mimetype;
      options.encoding = Encoding::Binary;
      options.ts_user = tuple.ts_user;
      try {
        kernel_->set("image", std::move(image->data), options);
      } catch (const Error& e) {
        std::cerr << "peis-camera: " << e.what() << "\n";
      }
    }
    lock.lock();
    if (image) ++frames_;
  }
}

std::string CameraNode::run() { return kernel_->run(); }

}  // namespace peis::camera
