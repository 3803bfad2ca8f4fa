// peis-navigation: the navigation PEIS-component (ThinkingCap-like). Takes
// ExecGoal tuples (GoTo(bed), GoTo(X, Y[, THETA]), Stop), plans on the map
// server's occupancy grid, drives the robot through its driver's VelCommand,
// localizes from its mi-position input when fresh and from odometry
// otherwise, and reports ExecStatus. The logic is the pure Navigator
// (core/); this file is the shell around it: tuples in, tuples out.
// docs/components/navigation.md.
#include <peis/component.h>

#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>

#include "execution/exec_server.h"
#include "execution/program_options.h"
#include "navigation_descriptor.h"
#include "robot_link.h"

namespace {

const char* kUsage = R"usage(Usage: peis-navigation [OPTIONS] [--peis-* flags]

The navigation component of a robot: takes ExecGoal tuples (GoTo(bed),
GoTo(X, Y), GoTo(X, Y, THETA), Stop), plans on the map server's grid, drives the
robot through its driver's VelCommand and publishes ExecStatus.

Options:
  --base NAME           the robot's driver PEIS (default: <peis name>-base)
  --map-server NAME     the PEIS with map, map.info and place.* (default: world)
  --robot NAME          the robot's name in path.<robot> (default: the driver's
                        name without -base)
  --descriptor FILE     functionality descriptor (default: the built-in navigation.yaml)
  --fix-freshness S     a position fix older than S seconds of sensor time is
                        stale: dead reckoning from the last fix (default 1.0)
  --max-speed V         m/s (default 0.35; the driver's limit wins if lower)
  --goal-tolerance M    metres (default 0.03)
  --safety-margin M     metres kept beyond the robot's radius (default 0.02)
  --help                this text

Tuples: ExecGoal (in, write it remotely), ExecStatus, pose, path.<robot>;
mi-position (input: the tracker's position tuple, "X Y ..." with ts_user).
)usage";

struct Settings {
  std::string base, mapServer = "world", robot, descriptor;
  peis::nav::NavigatorOptions nav;
};

bool parseDouble(const std::string& text, double& out) {
  const auto v = peis::exec::parseNumber(text);
  if (!v || *v < 0) return false;
  out = *v;
  return true;
}

bool takeOption(Settings& s, const std::string& name, const std::string& value) {
  if (name == "--base")
    s.base = value;
  else if (name == "--map-server")
    s.mapServer = value;
  else if (name == "--robot")
    s.robot = value;
  else if (name == "--descriptor")
    s.descriptor = value;
  else if (name == "--fix-freshness")
    return parseDouble(value, s.nav.localizer.fixFreshness);
  else if (name == "--max-speed")
    return parseDouble(value, s.nav.follower.maxSpeed) && s.nav.follower.maxSpeed > 0;
  else if (name == "--goal-tolerance")
    return parseDouble(value, s.nav.follower.goalTolerance) && s.nav.follower.goalTolerance > 0;
  else if (name == "--safety-margin")
    return parseDouble(value, s.nav.inflation.safetyMargin);
  else
    return false;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (peis::exec::printedHelp(argc, argv, kUsage)) return 0;
  peis::Kernel kernel(argc, argv);
  Settings settings;
  if (const int code =
          peis::exec::parseProgramOptions(argc, argv, "peis-navigation", kUsage,
                                          [&settings](const std::string& n, const std::string& v) {
                                            return takeOption(settings, n, v);
                                          });
      code >= 0)
    return code;
  if (settings.base.empty()) settings.base = kernel.name() + "-base";
  if (settings.robot.empty()) settings.robot = peis::nav::robotNameOfDriver(settings.base);
  peis::Descriptor descriptor;
  try {
    descriptor = settings.descriptor.empty()
                     ? peis::Descriptor::fromYaml(kNavigationDescriptor, "navigation.yaml")
                     : peis::Descriptor::fromFile(settings.descriptor);
  } catch (const peis::Error& e) {
    std::cerr << "peis-navigation: " << e.what() << "\n";
    return 1;
  }
  peis::Component component(kernel, "navigation", descriptor);
  std::unique_ptr<peis::exec::ExecServer> server;
  peis::nav::RobotLink robot(
      kernel, {settings.base, settings.mapServer, settings.robot, "navigation"}, settings.nav,
      [&server](const peis::exec::ExecStatus& status) { server->publish(status); });
  server = std::make_unique<peis::exec::ExecServer>(
      kernel,
      [](const peis::exec::Action& a) -> std::optional<std::string> {
        if (a.name == "Stop" && a.args.empty()) return std::nullopt;
        if (a.name != "GoTo") return "navigation does GoTo(place), GoTo(X, Y[, THETA]) and Stop";
        if (a.args.empty() || a.args.size() > 3) return "GoTo takes a place or X, Y[, THETA]";
        if (a.args.size() >= 2)
          for (const auto& arg : a.args)
            if (!peis::exec::parseNumber(arg))
              return "GoTo(X, Y[, THETA]) takes numbers, not '" + arg + "'";
        return std::nullopt;
      },
      [&robot](const peis::exec::Action& a, std::uint64_t id) {
        robot.apply(robot.navigator().onGoal(a, id));
      });
  component.input("position", std::chrono::seconds(2),
                  [&robot](const peis::Tuple& t) { robot.onFix(t); });
  robot.start();
  component.start();
  kernel.run();
  return 0;
}
