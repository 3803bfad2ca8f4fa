// Test helper for the reference components as separate processes: starts the
// programs of the simulated home in an ecology of their own, runs `peis`
// commands, and reads the world's ground truth (physics.scene) through an
// observer Kernel in the test.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "peis/kernel.h"
#include "support/process.h"
#include "support/wait_for.h"

namespace peis::test {

// The path of one of the programs these tests start (set by tests/CMakeLists.txt).
inline std::string programPath(const std::string& name) {
  if (name == "peis-sim-world") return PEIS_SIM_WORLD_PATH;
  if (name == "peis-camera") return PEIS_CAMERA_PATH;
  if (name == "peis-tracker") return PEIS_TRACKER_PATH;
  if (name == "peis-navigation") return PEIS_NAVIGATION_PATH;
  if (name == "peis-executor") return PEIS_EXECUTOR_PATH;
  if (name == "peis-talk") return PEIS_TALK_PATH;
  if (name == "peis-photo-camera") return PEIS_PHOTO_CAMERA_PATH;
  if (name == "peis-vacuum") return PEIS_VACUUM_PATH;
  if (name == "peis-sim-sensors") return PEIS_SIM_SENSORS_PATH;
  if (name == "peis-configurator") return PEIS_CONFIGURATOR_PATH;
  return name;
}

struct Home {
  std::string ecology;
  std::vector<std::unique_ptr<Process>> processes;
  std::unique_ptr<Kernel> observer;

  explicit Home(const std::string& tag) : ecology(uniqueEcology(tag)) {
    Options options;
    options.ecology = ecology;
    options.name = "referee";
    observer = std::make_unique<Kernel>(options);
  }

  Process& start(const std::string& program, std::vector<std::string> args) {
    args.insert(args.begin(), program);
    args.push_back("--peis-ecology");
    args.push_back(ecology);
    processes.push_back(std::make_unique<Process>(args));
    return *processes.back();
  }

  // Runs `peis ARGS…` to its end; returns the exit status (-1 on a hang).
  int cli(std::vector<std::string> args, std::string* output = nullptr) {
    args.insert(args.begin(), peisCliPath());
    args.push_back("--peis-ecology");
    args.push_back(ecology);
    Process tool(args);
    const auto status = tool.wait(std::chrono::seconds(30));
    if (output) *output = tool.describe();
    return status.value_or(-1);
  }

  std::string describeAll() {
    std::string out;
    for (auto& p : processes) out += p->describe() + "\n";
    return out;
  }

  // Waits until a PEIS named `name` is known to the observer; its id or 0.
  PeisId await(const std::string& name,
               std::chrono::milliseconds deadline = std::chrono::seconds(30)) {
    PeisId id = 0;
    waitFor(
        [&] {
          try {
            id = observer->resolveOwner(name);
            return true;
          } catch (const Error&) {
            return false;
          }
        },
        deadline);
    return id;
  }

  // The ground-truth pose of a robot from the world's physics.scene.
  std::optional<std::vector<double>> truePose(PeisId world, const std::string& robot) {
    const auto scene = observer->get(world, "physics.scene");
    if (!scene) return std::nullopt;
    std::istringstream lines(scene->data);
    for (std::string line; std::getline(lines, line);) {
      std::istringstream fields(line);
      std::string kind, name;
      double x, y, theta;
      if (fields >> kind >> name >> x >> y >> theta && kind == "robot" && name == robot)
        return std::vector<double>{x, y, theta};
    }
    return std::nullopt;
  }
};

}  // namespace peis::test
