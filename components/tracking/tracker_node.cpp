// Camera tracking localization as a PEIS (tracker_node.h).
#include "tracker_node.h"

#include <cstdio>
#include <iostream>

#include "camera/image_tuple.h"
#include "peis/descriptor.h"
#include "peis/error.h"
#include "tracking/tracker_descriptor.h"
#include "tracking_descriptor.h"

namespace peis::tracking {

std::string formatPosition(const Fix& fix) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, "%.4f %.4f %.3e %.3e %.3e %d", fix.point.x(), fix.point.y(),
                fix.covariance(0, 0), fix.covariance(0, 1), fix.covariance(1, 1), fix.cameras);
  return buffer;
}

namespace {

// The calibration beside an image: "image" -> "calibration",
// "left.image" -> "left.calibration".
std::string calibrationKeyOf(const std::string& imageKey) {
  const auto dot = imageKey.rfind('.');
  return dot == std::string::npos ? "calibration" : imageKey.substr(0, dot) + ".calibration";
}

}  // namespace

TrackerNode::TrackerNode(TrackerConfig config)
    : config_(std::move(config)), detector_(config_.targets, config_.detector) {
  kernel_ = std::make_unique<Kernel>(config_.peis);
  component_ = std::make_unique<Component>(
      *kernel_, "tracker",
      trackerDescriptor(Descriptor::fromYaml(kTrackingDescriptor, "tracking.yaml"), config_.cameras,
                        config_.targets, config_.cost));
  cameras_.resize(static_cast<std::size_t>(config_.cameras));
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    cameras_[k].input = "camera" + std::to_string(k + 1);
    component_->input(cameras_[k].input, config_.freshness,
                      [this, k](const Tuple& t) { onImage(k, t); });
  }
  statsTimer_ = kernel_->every(std::chrono::seconds(1), [this] {
    const Stats s = stats();
    kernel_->set("tracker.stats", "images " + std::to_string(s.images) + " not-images " +
                                      std::to_string(s.notImages) + " no-calibration " +
                                      std::to_string(s.noCalibration) + " wrong-size " +
                                      std::to_string(s.wrongSize) + " fixes " +
                                      std::to_string(s.fixes));
  });
  component_->start();
}

TrackerNode::~TrackerNode() {
  if (statsTimer_) kernel_->cancelTimer(*statsTimer_);
  for (auto& c : cameras_)
    if (c.calibrationCallback != 0) kernel_->removeCallback(c.calibrationCallback);
  component_.reset();
  kernel_.reset();
}

TrackerNode::Stats TrackerNode::stats() const {
  std::lock_guard lock(statsMu_);
  return stats_;
}

std::string TrackerNode::run() { return kernel_->run(); }

void TrackerNode::problem(Camera& camera, const std::string& what) {
  // Said once per kind of problem per input, so a broken camera cannot flood the log.
  if (camera.lastProblem == what) return;
  camera.lastProblem = what;
  std::cerr << "peis-tracker: " << camera.input << ": " << what << "\n";
}

void TrackerNode::watchCalibration(Camera& camera, PeisId owner, const std::string& key) {
  if (camera.calibrationCallback != 0) kernel_->removeCallback(camera.calibrationCallback);
  camera.calibrationOwner = owner;
  camera.calibrationKey = key;
  camera.calibration.reset();
  const std::size_t index = static_cast<std::size_t>(&camera - cameras_.data());
  const auto apply = [this, index](const Tuple& t) {
    Camera& c = cameras_[index];
    if (t.owner != c.calibrationOwner || t.key != c.calibrationKey) return;
    try {
      c.calibration = camera::calibrationFromYaml(t.data, t.fullName());
    } catch (const Error& e) {
      c.calibration.reset();
      problem(c, std::string("broken calibration: ") + e.what());
    }
  };
  kernel_->subscribe(Pattern::exact(owner, key));
  camera.calibrationCallback = kernel_->onChange(Pattern::exact(owner, key), apply);
  if (auto known = kernel_->get(owner, key)) apply(*known);
}

void TrackerNode::onImage(std::size_t index, const Tuple& t) {
  Camera& camera = cameras_[index];
  const std::string key = calibrationKeyOf(t.key);
  if (t.owner != camera.calibrationOwner || key != camera.calibrationKey)
    watchCalibration(camera, t.owner, key);
  std::string why;
  const cv::Mat image = camera::decodeImage(t.mimetype, t.data, why);
  if (image.empty()) {
    {
      std::lock_guard lock(statsMu_);
      ++stats_.notImages;
    }
    problem(camera, "dropped a tuple that is not an image: " + why);
    return;
  }
  if (!camera.calibration) {
    {
      std::lock_guard lock(statsMu_);
      ++stats_.noCalibration;
    }
    problem(camera,
            "no calibration at " + std::to_string(t.owner) + "." + key + " (yet); image ignored");
    return;
  }
  if (image.cols != camera.calibration->width || image.rows != camera.calibration->height) {
    {
      std::lock_guard lock(statsMu_);
      ++stats_.wrongSize;
    }
    problem(camera, "dropped an image of " + std::to_string(image.cols) + "x" +
                        std::to_string(image.rows) + " (the calibration is for " +
                        std::to_string(camera.calibration->width) + "x" +
                        std::to_string(camera.calibration->height) + ")");
    return;
  }
  {
    std::lock_guard lock(statsMu_);
    ++stats_.images;
  }
  camera.lastProblem.clear();
  camera.detections = detector_.detect(image);
  camera.frameTime = t.ts_user != kNoTime ? t.ts_user : t.ts_write;
  trySolve(*camera.frameTime);
}

void TrackerNode::trySolve(Timestamp moment) {
  bool complete = true;
  for (const Camera& c : cameras_) {
    if (!c.calibration || !component_->inputFresh(c.input)) continue;  // not waited for
    if (!c.frameTime || *c.frameTime + config_.maxSkew < moment) complete = false;
  }
  if (complete) {
    solve(moment);
  } else {
    kernel_->after(config_.wait, [this, moment] { solve(moment); });
  }
}

void TrackerNode::solve(Timestamp moment) {
  // A moment is solved once, and again only when more of its images came
  // (a camera that was late): never an older moment.
  std::size_t images = 0;
  for (const Camera& c : cameras_)
    if (c.calibration && c.frameTime) {
      const auto skew = *c.frameTime > moment ? *c.frameTime - moment : moment - *c.frameTime;
      images += skew <= config_.maxSkew;
    }
  if (lastSolved_ &&
      (moment < *lastSolved_ || (moment == *lastSolved_ && images <= lastSolvedImages_)))
    return;
  lastSolved_ = moment;
  lastSolvedImages_ = images;
  for (std::size_t t = 0; t < config_.targets.size(); ++t) {
    std::vector<Sighting> sightings;
    Timestamp newest = kNoTime;
    for (const Camera& c : cameras_) {
      if (!c.calibration || !c.frameTime) continue;
      const auto skew = *c.frameTime > moment ? *c.frameTime - moment : moment - *c.frameTime;
      if (skew > config_.maxSkew) continue;
      for (const Detection& d : c.detections)
        if (d.target == t) {
          sightings.push_back({&*c.calibration, d.u, d.v});
          newest = std::max(newest, *c.frameTime);
        }
    }
    const auto fix = triangulate(sightings, config_.targets[t].height, config_.noise);
    if (!fix) continue;  // nobody sees it: nothing is published
    WriteOptions options;
    options.ts_user = newest;
    kernel_->set("position." + config_.targets[t].name, formatPosition(*fix), options);
    std::lock_guard lock(statsMu_);
    ++stats_.fixes;
  }
}

}  // namespace peis::tracking
