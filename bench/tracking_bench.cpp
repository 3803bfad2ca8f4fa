// peis-bench-tracking: accuracy of camera tracking against the simulation's
// ground truth, and time per 640x480 frame (docs/components/tracking.md,
// docs/performance.md). Robots are put at random free poses of the
// PEIS-Home; the living room's two ceiling cameras render them (with sensor
// noise), the tracker's core detects the hats and triangulates; the error is
// the distance from the true position. Prints markdown table rows.
//
//   peis-bench-tracking [--poses N] [--seed N] [--save DIR]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "camera/image_tuple.h"
#include "camera/render_view.h"
#include "sim/world/scene.h"
#include "tracking/hat_detector.h"
#include "tracking/targets.h"
#include "tracking/triangulation.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace peis;

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  const std::size_t at =
      std::min(values.size() - 1, static_cast<std::size_t>(p * (values.size() - 1) + 0.5));
  return values[at];
}

double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

// Milliseconds per call of `fn`: the median of `rounds` calls in CPU time
// of this thread (what one core spends, whatever else the machine runs)
// and in wall time.
struct PerCall {
  double cpu, wall;
};
template <typename Fn>
PerCall timePerCall(int rounds, Fn&& fn) {
  std::vector<double> cpu, wall;
  for (int i = 0; i < rounds; ++i) {
    const auto start = Clock::now();
    const double startCpu = threadCpuMs();
    fn();
    cpu.push_back(threadCpuMs() - startCpu);
    wall.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }
  return {percentile(cpu, 0.5), percentile(wall, 0.5)};
}

struct Errors {
  std::vector<double> metres;
  int attempts = 0;
  void row(const char* what) const {
    std::printf("| %s | %zu of %d | %.1f | %.1f | %.1f |\n", what, metres.size(), attempts,
                percentile(metres, 0.5) * 100, percentile(metres, 0.95) * 100,
                metres.empty() ? NAN : *std::max_element(metres.begin(), metres.end()) * 100);
  }
};

}  // namespace

int main(int argc, char** argv) {
  int poses = 300;
  unsigned seed = 1;
  std::string save;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help") {
      std::printf("Usage: peis-bench-tracking [--poses N] [--seed N] [--save DIR]\n");
      return 0;
    } else if (arg == "--poses" && i + 1 < argc) {
      poses = std::max(1, std::atoi(argv[++i]));
    } else if (arg == "--seed" && i + 1 < argc) {
      seed = static_cast<unsigned>(std::atoi(argv[++i]));
    } else if (arg == "--save" && i + 1 < argc) {
      save = argv[++i];
    } else {
      std::fprintf(stderr, "peis-bench-tracking: unknown argument %s (see --help)\n", arg.c_str());
      return 2;
    }
  }
  const std::string homePath =
      std::string(PEIS_SOURCE_DIR) + "/components/sim/homes/peis-home.yaml";
  const sim::World world = sim::loadWorldFile(homePath);
  const sim::LightModel light(world);
  const auto targets = tracking::loadTargets(homePath);
  const auto& c1 = *world.camera("living-1");
  const auto& c2 = *world.camera("living-2");
  tracking::HatDetector detector(targets);
  const tracking::NoiseModel noise;

  // Random free poses in the living room for every robot at once.
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(0.3, 4.7), y(0.3, 5.7), heading(-M_PI, M_PI);
  sim::Simulation simulation(world, seed);
  Errors two, one;
  std::vector<cv::Mat> frames;
  for (int n = 0; n < poses; ++n) {
    sim::Scene scene = sim::sceneOf(simulation);
    std::vector<sim::Vec2> placed;
    for (std::size_t r = 0; r < world.robots.size(); ++r) {
      sim::Vec2 p;
      for (int tries = 0; tries < 1000; ++tries) {
        p = {x(rng), y(rng)};
        bool free = simulation.diskFree(p, world.robots[r].radius, r, std::nullopt);
        for (const auto& q : placed) free = free && (q - p).norm() > 0.5;
        // Not on the parcel either (the simulation checks it at its start pose).
        if (free) break;
      }
      placed.push_back(p);
      scene.robots[r].pose = {p.x, p.y, heading(rng)};
    }
    const cv::Mat image1 = camera::renderView(world, light, scene, c1, seed * 7919u + n * 2);
    const cv::Mat image2 = camera::renderView(world, light, scene, c2, seed * 7919u + n * 2 + 1);
    if (frames.size() < 8) frames.push_back(image1), frames.push_back(image2);
    if (!save.empty() && n < 4) {
      std::filesystem::create_directories(save);
      cv::imwrite(save + "/living-1-" + std::to_string(n) + ".png", image1);
      cv::imwrite(save + "/living-2-" + std::to_string(n) + ".png", image2);
    }
    const auto d1 = detector.detect(image1);
    const auto d2 = detector.detect(image2);
    for (std::size_t t = 0; t < targets.size(); ++t) {
      const sim::Pose2 truth = scene.robots[t].pose;
      // Which cameras see the hat in full (ground truth, for the bookkeeping).
      const Eigen::Vector3d hat(truth.x, truth.y, targets[t].height);
      std::vector<tracking::Sighting> seen;
      std::optional<tracking::Sighting> first;
      for (const auto& d : d1)
        if (d.target == t) seen.push_back({&c1.calibration, d.u, d.v}), first = seen.back();
      for (const auto& d : d2)
        if (d.target == t) seen.push_back({&c2.calibration, d.u, d.v});
      const auto p1 = c1.calibration.project(hat), p2 = c2.calibration.project(hat);
      const bool inBoth = p1 && p2 && c1.calibration.inImage(*p1) && c2.calibration.inImage(*p2);
      if (inBoth) {
        ++two.attempts;
        if (seen.size() == 2)
          if (auto fix = tracking::triangulate(seen, targets[t].height, noise))
            two.metres.push_back(std::hypot(fix->point.x() - truth.x, fix->point.y() - truth.y));
      }
      if (p1 && c1.calibration.inImage(*p1)) {
        ++one.attempts;
        if (first)
          if (auto fix = tracking::triangulate({*first}, targets[t].height, noise))
            one.metres.push_back(std::hypot(fix->point.x() - truth.x, fix->point.y() - truth.y));
      }
    }
  }
  std::printf(
      "Accuracy: %d random scenes of the PEIS-Home, all four robots placed at random free\n"
      "poses in the living room each time (seed %u), cameras living-1 and living-2 (640x480,\n"
      "fx 380, noise sigma 2). Error = horizontal distance to the true position.\n\n",
      poses, seed);
  std::printf(
      "| fix | found / hats in view | median (cm) | p95 (cm) | max (cm) "
      "|\n|---|---|---|---|---|\n");
  two.row("two cameras (triangulation)");
  one.row("one camera (living-1, hat plane)");

  // Time per 640x480 frame on this core.
  std::vector<camera::EncodedImage> raws, pngs;
  for (const auto& f : frames) {
    raws.push_back(camera::encodeImage(f, camera::ImageFormat::Raw));
    pngs.push_back(camera::encodeImage(f, camera::ImageFormat::Png));
  }
  std::size_t k = 0;
  const int rounds = 400;
  const PerCall detectMs =
      timePerCall(rounds, [&] { detector.detect(frames[k++ % frames.size()]); });
  std::string why;
  const PerCall rawMs = timePerCall(rounds, [&] {
    const auto& e = raws[k++ % raws.size()];
    detector.detect(camera::decodeImage(e.mimetype, e.data, why));
  });
  const PerCall pngMs = timePerCall(rounds / 4, [&] {
    const auto& e = pngs[k++ % pngs.size()];
    detector.detect(camera::decodeImage(e.mimetype, e.data, why));
  });
  std::vector<tracking::Sighting> pair;
  {
    const Eigen::Vector3d hat(2.5, 3.0, 0.52);
    const auto a = c1.calibration.project(hat), b = c2.calibration.project(hat);
    pair = {{&c1.calibration, a->x(), a->y()}, {&c2.calibration, b->x(), b->y()}};
  }
  const PerCall triangulateMs =
      timePerCall(2000, [&] { tracking::triangulate(pair, 0.52, noise); });
  sim::Scene scene = sim::sceneOf(simulation);
  const PerCall renderMs =
      timePerCall(50, [&] { camera::renderView(world, light, scene, c1, k++); });
  std::size_t pngBytes = 0;
  for (const auto& p : pngs) pngBytes += p.data.size();
  std::printf(
      "\nTime per 640x480 frame, median of %d (CPU: this thread's CPU time; wall: elapsed):\n\n"
      "| step | CPU ms | wall ms |\n|---|---|---|\n",
      rounds);
  std::printf("| hat detection (HSV, one labelling pass, blobs of %zu targets) | %.2f | %.2f |\n",
              targets.size(), detectMs.cpu, detectMs.wall);
  std::printf("| decode raw bgr8 (%zu bytes) + detection | %.2f | %.2f |\n", raws[0].data.size(),
              rawMs.cpu, rawMs.wall);
  std::printf("| decode PNG (%zu bytes on average) + detection | %.2f | %.2f |\n",
              pngBytes / pngs.size(), pngMs.cpu, pngMs.wall);
  std::printf("| triangulation of one robot from two cameras | %.4f | %.4f |\n", triangulateMs.cpu,
              triangulateMs.wall);
  std::printf(
      "| rendering one camera image (the simulated camera, for reference) | %.2f | %.2f |\n",
      renderMs.cpu, renderMs.wall);
  return 0;
}
