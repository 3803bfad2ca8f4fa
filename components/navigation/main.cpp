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
#include <map>
#include <string>

#include "execution/exec_server.h"
#include "navigation_descriptor.h"
#include "navigator.h"

namespace {

const char* kUsage = R"(Usage: peis-navigation [OPTIONS] [--peis-* flags]

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
)";

struct Settings {
  std::string base, mapServer = "world", robot, descriptor;
  peis::nav::NavigatorOptions nav;
};

bool parseDouble(const char* text, double& out) {
  const auto v = peis::exec::parseNumber(text);
  if (!v || *v < 0) return false;
  out = *v;
  return true;
}

int parseArgs(int argc, char** argv, Settings& s) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage << "\n" << peis::Options::helpText();
      return 0;
    }
    if (i + 1 >= argc) {
      std::cerr << "peis-navigation: unknown option or missing value: " << arg << "\n" << kUsage;
      return 2;
    }
    const char* value = argv[++i];
    bool ok = true;
    if (arg == "--base")
      s.base = value;
    else if (arg == "--map-server")
      s.mapServer = value;
    else if (arg == "--robot")
      s.robot = value;
    else if (arg == "--descriptor")
      s.descriptor = value;
    else if (arg == "--fix-freshness")
      ok = parseDouble(value, s.nav.localizer.fixFreshness);
    else if (arg == "--max-speed")
      ok = parseDouble(value, s.nav.follower.maxSpeed) && s.nav.follower.maxSpeed > 0;
    else if (arg == "--goal-tolerance")
      ok = parseDouble(value, s.nav.follower.goalTolerance) && s.nav.follower.goalTolerance > 0;
    else if (arg == "--safety-margin")
      ok = parseDouble(value, s.nav.inflation.safetyMargin);
    else {
      std::cerr << "peis-navigation: unknown option " << arg << "\n" << kUsage;
      return 2;
    }
    if (!ok) {
      std::cerr << "peis-navigation: " << arg << " takes a non-negative number, not '" << value
                << "'\n";
      return 2;
    }
  }
  return -1;
}

std::string formatPath(const std::vector<peis::nav::Point2>& path) {
  std::string out;
  char buf[48];
  for (const auto& p : path) {
    std::snprintf(buf, sizeof buf, "%s%.4f %.4f", out.empty() ? "" : " ", p.x, p.y);
    out += buf;
  }
  return out;
}

// Everything the callbacks share; used on the kernel thread only.
struct Shell {
  peis::Kernel& kernel;
  Settings settings;
  peis::nav::Navigator navigator;
  peis::PeisId base = 0, mapServer = 0;
  std::optional<peis::Tuple> mapTuple, mapInfoTuple;
  std::map<std::string, peis::nav::Pose2> places;
  std::unique_ptr<peis::exec::ExecServer> server;
  peis::nav::PoseSource lastSource = peis::nav::PoseSource::None;

  void log(const std::string& line) { std::cerr << "navigation: " << line << std::endl; }

  void apply(const peis::nav::NavOutput& out) {
    for (const auto& line : out.log) log(line);
    for (const auto& status : out.statuses) server->publish(status);
    if (out.path) kernel.set("path." + settings.robot, formatPath(*out.path));
    if (out.command && base != 0) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.4f %.5f", out.command->v, out.command->w);
      kernel.setAsync(base, "VelCommand", buf, {},
                      [this](const std::optional<peis::Error>& e, std::uint64_t) {
                        if (e && e->code() != peis::ErrorCode::Timeout)
                          log(std::string("VelCommand refused: ") + e->what());
                      });
    }
  }

  void tryMap() {
    if (!mapTuple || !mapInfoTuple) return;
    try {
      const auto info = peis::nav::parseMapInfo(mapInfoTuple->data);
      navigator.setMap(peis::nav::parsePgmMap(mapTuple->data, info));
      log("map " + std::to_string(info.width) + "x" + std::to_string(info.height) + " cells at " +
          std::to_string(info.resolution) + " m");
    } catch (const peis::nav::MapError& e) {
      log(std::string("cannot use the map: ") + e.what());
    }
  }

  void onOdometry(const peis::Tuple& t) {
    const auto v = peis::exec::parseNumbers(t.data);
    if (!v || v->size() < 3)
      return log("malformed Odometry '" + t.data.substr(0, 60) + "' ignored");
    const double time = peis::exec::sensorSeconds(t).value_or(
        std::chrono::duration<double>(peis::systemNow().time_since_epoch()).count());
    apply(navigator.onOdometry({(*v)[0], (*v)[1], (*v)[2]}, time));
    const auto estimate = navigator.localizer().estimate();
    if (!estimate) return;
    if (estimate->source != lastSource) {
      log(std::string("localizing from ") + toString(estimate->source));
      lastSource = estimate->source;
    }
    char buf[96];
    std::snprintf(buf, sizeof buf, "%.4f %.4f %.5f %s", estimate->pose.x, estimate->pose.y,
                  estimate->pose.theta, toString(estimate->source));
    peis::WriteOptions options;
    options.ts_user = t.ts_user;
    kernel.set("pose", buf, options);
  }

  void onFix(const peis::Tuple& t) {
    const auto v = peis::exec::parseNumbers(t.data);
    if (!v || v->size() < 2)
      return log("malformed position '" + t.data.substr(0, 60) + "' ignored");
    const auto time = peis::exec::sensorSeconds(t);
    const auto latest = navigator.localizer().estimate();
    if (!latest) return;
    navigator.onFix({(*v)[0], (*v)[1]}, time.value_or(latest->time));
  }

  void onGeometry() {
    auto number = [&](const char* key, double fallback) {
      const auto t = kernel.get(base, key);
      const auto v = t ? peis::exec::parseNumbers(t->data) : std::nullopt;
      return v && !v->empty() ? (*v)[0] : fallback;
    };
    const auto sonar = kernel.get(base, "Geometry.sonar");
    const auto angles = sonar ? peis::exec::parseNumbers(sonar->data) : std::nullopt;
    const auto speed = kernel.get(base, "Geometry.max-speed");
    const auto limits = speed ? peis::exec::parseNumbers(speed->data) : std::nullopt;
    navigator.setGeometry(number("Geometry.radius", 0.2), angles.value_or(std::vector<double>{}),
                          number("Geometry.max-range", 3.0),
                          limits && limits->size() == 2 ? (*limits)[0] : 0,
                          limits && limits->size() == 2 ? (*limits)[1] : 0);
  }
};

}  // namespace

int main(int argc, char** argv) {
  peis::Kernel kernel(argc, argv);
  Settings settings;
  if (const int code = parseArgs(argc, argv, settings); code >= 0) return code;
  if (settings.base.empty()) settings.base = kernel.name() + "-base";
  if (settings.robot.empty()) {
    settings.robot = settings.base;
    const auto dash = settings.robot.rfind("-base");
    if (dash != std::string::npos && dash + 5 == settings.robot.size()) settings.robot.resize(dash);
  }
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
  auto shell = std::make_shared<Shell>(Shell{kernel,
                                             settings,
                                             peis::nav::Navigator(settings.nav, {}),
                                             0,
                                             0,
                                             {},
                                             {},
                                             {},
                                             {},
                                             peis::nav::PoseSource::None});
  Shell& s = *shell;
  s.navigator = peis::nav::Navigator(
      settings.nav, [&s](const std::string& name) -> std::optional<peis::nav::Pose2> {
        if (s.mapServer == 0) return std::nullopt;
        const auto t = s.kernel.get(s.mapServer, "place." + name);
        if (!t) return std::nullopt;
        const auto v = peis::exec::parseNumbers(t->data);
        if (!v || v->size() < 2) return std::nullopt;
        return peis::nav::Pose2{(*v)[0], (*v)[1], v->size() >= 3 ? (*v)[2] : 0.0};
      });
  s.server = std::make_unique<peis::exec::ExecServer>(
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
      [&s](const peis::exec::Action& a, std::uint64_t id) { s.apply(s.navigator.onGoal(a, id)); });

  component.input("position", std::chrono::seconds(2), [&s](const peis::Tuple& t) { s.onFix(t); });

  peis::exec::whenPeerKnown(kernel, settings.base, [&s](peis::PeisId id) {
    s.base = id;
    s.log("driver " + s.settings.base + " is PEIS " + std::to_string(id));
    s.kernel.onChange(peis::Pattern("Odometry", id),
                      [&s](const peis::Tuple& t) { s.onOdometry(t); });
    s.kernel.onChange(peis::Pattern("Bumper", id),
                      [&s](const peis::Tuple& t) { s.navigator.onBumper(t.data == "1"); });
    s.kernel.onChange(peis::Pattern("SonarRange", id), [&s](const peis::Tuple& t) {
      if (const auto v = peis::exec::parseNumbers(t.data)) s.navigator.onSonar(*v);
    });
    s.kernel.onChange(peis::Pattern("Geometry.*", id),
                      [&s](const peis::Tuple&) { s.onGeometry(); });
    for (const char* key : {"Odometry", "Bumper", "SonarRange", "Geometry.*"})
      s.kernel.subscribe(peis::Pattern(key, id));
    s.onGeometry();
  });
  peis::exec::whenPeerKnown(kernel, settings.mapServer, [&s](peis::PeisId id) {
    s.mapServer = id;
    s.log("map server " + s.settings.mapServer + " is PEIS " + std::to_string(id));
    s.kernel.onChange(peis::Pattern("map", id), [&s](const peis::Tuple& t) {
      s.mapTuple = t;
      s.tryMap();
    });
    s.kernel.onChange(peis::Pattern("map.info", id), [&s](const peis::Tuple& t) {
      s.mapInfoTuple = t;
      s.tryMap();
    });
    for (const char* key : {"map", "map.info", "place.*", "places"})
      s.kernel.subscribe(peis::Pattern(key, id));
  });
  component.start();
  kernel.run();
  shell->server.reset();
  return 0;
}
