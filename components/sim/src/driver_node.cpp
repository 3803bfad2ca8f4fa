// A simulated robot's driver PEIS (driver_node.h).
#include "driver_node.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "base_descriptor.h"
#include "peis/descriptor.h"
#include "peis/error.h"

namespace peis::sim {
namespace {

std::string numbers(std::initializer_list<double> values, const char* format) {
  std::string out;
  char buffer[48];
  for (double v : values) {
    std::snprintf(buffer, sizeof buffer, format, v);
    out += (out.empty() ? "" : " ") + std::string(buffer);
  }
  return out;
}

WriteOptions at(Timestamp stamp) {
  WriteOptions options;
  options.ts_user = stamp;
  return options;
}

// Keys the driver alone writes.
bool isOutput(const std::string& key) {
  return key == "Odometry" || key == "SonarRange" || key == "Bumper" || key == "Battery" ||
         key.rfind("Geometry.", 0) == 0;
}

}  // namespace

std::optional<Velocity> parseVelCommand(std::string_view text) {
  std::istringstream in{std::string(text)};
  Velocity v;
  std::string rest;
  if (!(in >> v.v >> v.w) || (in >> rest) || !std::isfinite(v.v) || !std::isfinite(v.w))
    return std::nullopt;
  return v;
}

DriverNode::DriverNode(Options options, const Robot& robot, std::function<void(Velocity)> onCommand,
                       std::function<void(std::string)> onTalk)
    : robot_(robot.name) {
  kernel_ = std::make_unique<Kernel>(std::move(options));
  kernel_->setWriteGate([](const Tuple& t, PeisId, const WriteDecision& decide) {
    if (t.key == "VelCommand" && !parseVelCommand(t.data)) {
      decide(Error(ErrorCode::Refused,
                   "VelCommand takes 'V W' (m/s rad/s, two finite numbers), not '" +
                       t.data.substr(0, 60) + "'"));
      return true;
    }
    if (t.key == "TalkCommand" && t.data.size() > kMaxTalkBytes) {
      decide(Error(ErrorCode::Refused, "TalkCommand takes at most 200 bytes of text"));
      return true;
    }
    if (isOutput(t.key)) {
      decide(
          Error(ErrorCode::Refused, t.key + " is the driver's reading; only the driver writes it"));
      return true;
    }
    return false;
  });
  callbacks_.push_back(
      kernel_->onChange(Pattern("VelCommand", kernel_->id()), [onCommand](const Tuple& t) {
        if (auto v = parseVelCommand(t.data)) onCommand(*v);
      }));
  callbacks_.push_back(kernel_->onChange(Pattern("TalkCommand", kernel_->id()),
                                         [onTalk](const Tuple& t) { onTalk(t.data); }));
  component_ = std::make_unique<Component>(*kernel_, "base",
                                           Descriptor::fromYaml(kBaseDescriptor, "base.yaml"));
  kernel_->set("Geometry.radius", numbers({robot.radius}, "%.4f"));
  std::string sonar;
  for (double a : robot.sonarAngles) sonar += (sonar.empty() ? "" : " ") + numbers({a}, "%.4f");
  kernel_->set("Geometry.sonar", sonar);
  kernel_->set("Geometry.max-range", numbers({robot.sonarMaxRange}, "%.4f"));
  kernel_->set("Geometry.max-speed", numbers({robot.maxSpeed, robot.maxTurn}, "%.4f"));
  component_->start();
}

DriverNode::~DriverNode() {
  for (auto handle : callbacks_) kernel_->removeCallback(handle);
  component_.reset();
  kernel_.reset();
}

void DriverNode::publishOdometry(Pose2 p, Velocity v, Timestamp stamp) {
  kernel_->set("Odometry",
               numbers({p.x, p.y}, "%.4f") + " " + numbers({p.theta}, "%.5f") + " " +
                   numbers({v.v}, "%.4f") + " " + numbers({v.w}, "%.5f"),
               at(stamp));
}

void DriverNode::publishSonar(const std::vector<double>& ranges, Timestamp stamp) {
  std::string text;
  for (double r : ranges) text += (text.empty() ? "" : " ") + numbers({r}, "%.4f");
  kernel_->set("SonarRange", text, at(stamp));
}

void DriverNode::publishBumper(bool pressed, Timestamp stamp) {
  if (bumper_ == pressed) return;
  bumper_ = pressed;
  kernel_->set("Bumper", pressed ? "1" : "0", at(stamp));
}

void DriverNode::publishBattery(double percent, Timestamp stamp) {
  kernel_->set("Battery", numbers({percent}, "%.1f"), at(stamp));
}

}  // namespace peis::sim
