// The kernel side of a navigating robot (see robot_link.h).
#include "robot_link.h"

#include <cstdio>
#include <iostream>

#include "execution/exec_server.h"

namespace peis::nav {

std::string robotNameOfDriver(const std::string& driver) {
  const auto at = driver.rfind("-base");
  return at != std::string::npos && at + 5 == driver.size() && at > 0 ? driver.substr(0, at)
                                                                      : driver;
}

namespace {

std::string formatPath(const std::vector<Point2>& path) {
  std::string out;
  char buf[48];
  for (const auto& p : path) {
    std::snprintf(buf, sizeof buf, "%s%.4f %.4f", out.empty() ? "" : " ", p.x, p.y);
    out += buf;
  }
  return out;
}

}  // namespace

RobotLink::RobotLink(Kernel& kernel, RobotLinkSettings settings, const NavigatorOptions& options,
                     StatusHandler onStatus)
    : kernel_(kernel),
      settings_(std::move(settings)),
      onStatus_(std::move(onStatus)),
      navigator_(options, [this](const std::string& name) -> std::optional<Pose2> {
        const auto t = mapServerTuple("place." + name);
        const auto v = t ? exec::parseNumbers(t->data) : std::nullopt;
        if (!v || v->size() < 2) return std::nullopt;
        return Pose2{(*v)[0], (*v)[1], v->size() >= 3 ? (*v)[2] : 0.0};
      }) {}

void RobotLink::log(const std::string& line) const {
  std::cerr << settings_.logPrefix << ": " << line << std::endl;
}

std::optional<Tuple> RobotLink::mapServerTuple(const std::string& key) const {
  if (mapServer_ == 0) return std::nullopt;
  return kernel_.get(mapServer_, key);
}

void RobotLink::apply(const NavOutput& out) {
  for (const auto& line : out.log) log(line);
  for (const auto& status : out.statuses) onStatus_(status);
  if (out.path) kernel_.set("path." + settings_.robot, formatPath(*out.path));
  if (out.command && base_ != 0) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4f %.5f", out.command->v, out.command->w);
    WriteOptions stamped;
    stamped.ts_user = lastOdometryStamp_;  // the reading the command answers
    kernel_.setAsync(base_, "VelCommand", buf, stamped,
                     [this](const std::optional<Error>& e, std::uint64_t) {
                       if (e && e->code() != ErrorCode::Timeout)
                         log(std::string("VelCommand refused: ") + e->what());
                     });
  }
}

void RobotLink::tryMap() {
  if (!map_ || !mapInfo_) return;
  try {
    const auto info = parseMapInfo(mapInfo_->data);
    navigator_.setMap(parsePgmMap(map_->data, info));
    log("map " + std::to_string(info.width) + "x" + std::to_string(info.height) + " cells");
  } catch (const MapError& e) {
    log(std::string("cannot use the map: ") + e.what());
  }
}

void RobotLink::onOdometry(const Tuple& t) {
  const auto v = exec::parseNumbers(t.data);
  if (!v || v->size() < 3) return log("malformed Odometry '" + t.data.substr(0, 60) + "' ignored");
  const double time = exec::sensorSeconds(t).value_or(
      std::chrono::duration<double>(systemNow().time_since_epoch()).count());
  lastOdometryStamp_ = t.ts_user;
  apply(navigator_.onOdometry({(*v)[0], (*v)[1], (*v)[2]}, time));
  const auto estimate = navigator_.localizer().estimate();
  if (!estimate) return;
  if (estimate->source != lastSource_) {
    log(std::string("localizing from ") + toString(estimate->source));
    lastSource_ = estimate->source;
  }
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.4f %.4f %.5f %s", estimate->pose.x, estimate->pose.y,
                estimate->pose.theta, toString(estimate->source));
  WriteOptions options;
  options.ts_user = t.ts_user;
  kernel_.set("pose", buf, options);
}

void RobotLink::onFix(const Tuple& t) {
  const auto v = exec::parseNumbers(t.data);
  if (!v || v->size() < 2) return log("malformed position '" + t.data.substr(0, 60) + "' ignored");
  const auto latest = navigator_.localizer().estimate();
  if (!latest) return;
  navigator_.onFix({(*v)[0], (*v)[1]}, exec::sensorSeconds(t).value_or(latest->time));
}

void RobotLink::onGeometry() {
  auto numbers = [&](const char* key) {
    const auto t = kernel_.get(base_, key);
    return t ? exec::parseNumbers(t->data) : std::nullopt;
  };
  const auto radius = numbers("Geometry.radius");
  const auto range = numbers("Geometry.max-range");
  const auto limits = numbers("Geometry.max-speed");
  const bool speeds = limits && limits->size() == 2;
  navigator_.setGeometry(radius && !radius->empty() ? (*radius)[0] : 0.2,
                         numbers("Geometry.sonar").value_or(std::vector<double>{}),
                         range && !range->empty() ? (*range)[0] : 3.0, speeds ? (*limits)[0] : 0,
                         speeds ? (*limits)[1] : 0);
}

void RobotLink::start() {
  exec::whenPeerKnown(kernel_, settings_.base, [this](PeisId id) {
    base_ = id;
    log("driver " + settings_.base + " is PEIS " + std::to_string(id));
    kernel_.onValue(Pattern("Odometry", id), [this](const Tuple& t) { onOdometry(t); });
    kernel_.onValue(Pattern("Bumper", id),
                    [this](const Tuple& t) { navigator_.onBumper(t.data == "1"); });
    kernel_.onValue(Pattern("SonarRange", id), [this](const Tuple& t) {
      if (const auto v = exec::parseNumbers(t.data)) navigator_.onSonar(*v);
    });
    kernel_.onValue(Pattern("Geometry.*", id), [this](const Tuple&) { onGeometry(); });
    for (const char* key : {"Odometry", "Bumper", "SonarRange", "Geometry.*"})
      kernel_.subscribe(Pattern(key, id));
    onGeometry();
  });
  exec::whenPeerKnown(kernel_, settings_.mapServer, [this](PeisId id) {
    mapServer_ = id;
    log("map server " + settings_.mapServer + " is PEIS " + std::to_string(id));
    kernel_.onValue(Pattern("map", id), [this](const Tuple& t) {
      map_ = t;
      tryMap();
    });
    kernel_.onValue(Pattern("map.info", id), [this](const Tuple& t) {
      mapInfo_ = t;
      tryMap();
    });
    for (const char* key : {"map", "map.info", "place.*", "places", "room.*", "rooms"})
      kernel_.subscribe(Pattern(key, id));
  });
}

}  // namespace peis::nav
