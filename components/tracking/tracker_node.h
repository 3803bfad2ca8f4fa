// TrackerNode: camera tracking localization as a PEIS (peis-tracker). Its
// inputs mi-camera1..mi-cameraN are meta tuples a configurator points at
// cameras' `image` tuples; the calibration is read from the tuple beside
// each image (`image` -> `calibration`, `left.image` -> `left.calibration`). Each image is decoded,
// its hats detected; the images of one moment (the same simulated time within a skew) are
// triangulated together, and `position.<robot>` is published for every
// robot seen by at least one camera (docs/components/tracking.md).
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "camera/calibration.h"
#include "peis/component.h"
#include "peis/kernel.h"
#include "tracking/hat_detector.h"
#include "tracking/triangulation.h"

namespace peis::tracking {

struct TrackerConfig {
  std::vector<Target> targets;
  int cameras = 2;
  NoiseModel noise;
  DetectorSettings detector;
  std::chrono::milliseconds freshness{2000};  // an input older than this is not waited for
  std::chrono::milliseconds wait{150};        // for the other cameras' images of a moment
  std::chrono::microseconds maxSkew{50000};   // images this close in time are one moment
  std::optional<double> cost;                 // the descriptor's cost, when not the template's
  Options peis;
};

// "X Y VXX VXY VYY CAMERAS" of a fix (the position tuple's data).
std::string formatPosition(const Fix& fix);

class TrackerNode {
 public:
  explicit TrackerNode(TrackerConfig config);
  ~TrackerNode();
  Kernel& kernel() { return *kernel_; }
  std::string run();

  struct Stats {
    std::uint64_t images = 0, notImages = 0, noCalibration = 0, wrongSize = 0, fixes = 0;
  };
  Stats stats() const;

 private:
  struct Camera {
    std::string input;
    PeisId calibrationOwner = 0;
    std::string calibrationKey;
    CallbackHandle calibrationCallback = 0;
    std::optional<camera::Calibration> calibration;
    std::optional<Timestamp> frameTime;
    std::vector<Detection> detections;
    std::string lastProblem;
  };

  void onImage(std::size_t index, const Tuple& t);
  void watchCalibration(Camera& camera, PeisId owner, const std::string& key);
  void trySolve(Timestamp moment);
  void solve(Timestamp moment);
  void problem(Camera& camera, const std::string& what);

  TrackerConfig config_;
  std::unique_ptr<Kernel> kernel_;
  std::unique_ptr<Component> component_;
  HatDetector detector_;
  std::vector<Camera> cameras_;  // touched on the kernel thread only
  std::optional<Timestamp> lastSolved_;
  std::size_t lastSolvedImages_ = 0;
  Stats stats_;
  mutable std::mutex statsMu_;
  std::optional<TimerHandle> statsTimer_;
};

}  // namespace peis::tracking
