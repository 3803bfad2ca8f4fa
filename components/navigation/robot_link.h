// The kernel side of a robot that navigates, shared by peis-navigation and
// peis-vacuum: subscribes to the robot's driver (Odometry, Bumper,
// SonarRange, Geometry.*) and the map server (map, map.info, place.*,
// room.*), feeds them to a Navigator, and carries out its output: VelCommand
// to the driver, path.<robot>, pose; statuses go to a handler the program
// chooses. Runs on the kernel thread only.
#pragma once

#include <peis/kernel.h>

#include <functional>
#include <optional>
#include <string>

#include "navigator.h"

namespace peis::nav {

struct RobotLinkSettings {
  std::string base;  // the driver PEIS
  std::string mapServer = "world";
  std::string robot;  // for path.<robot>
  std::string logPrefix = "navigation";
};

class RobotLink {
 public:
  using StatusHandler = std::function<void(const exec::ExecStatus&)>;
  RobotLink(Kernel& kernel, RobotLinkSettings settings, const NavigatorOptions& options,
            StatusHandler onStatus);
  // Starts looking for the driver and the map server.
  void start();

  Navigator& navigator() { return navigator_; }
  void apply(const NavOutput& out);
  // A position fix tuple ("X Y …", ts_user = the time of the images).
  void onFix(const Tuple& fix);
  // A tuple of the map server (`room.living-room`), if known.
  std::optional<Tuple> mapServerTuple(const std::string& key) const;
  void log(const std::string& line) const;

 private:
  void tryMap();
  void onOdometry(const Tuple& t);
  void onGeometry();

  Kernel& kernel_;
  RobotLinkSettings settings_;
  StatusHandler onStatus_;
  Navigator navigator_;
  PeisId base_ = 0, mapServer_ = 0;
  std::optional<Tuple> map_, mapInfo_;
  PoseSource lastSource_ = PoseSource::None;
  Timestamp lastOdometryStamp_ = kNoTime;
};

// "…-base" -> "…": the robot's name from its driver's.
std::string robotNameOfDriver(const std::string& driver);

}  // namespace peis::nav
