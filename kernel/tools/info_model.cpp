// PeisInfo from a PEIS's tuples, and its text and JSON forms; see info_model.h.
#include "info_model.h"

#include <algorithm>
#include <map>
#include <sstream>

#include "lookup.h"
#include "output.h"
#include "peis/conventions.h"
#include "peis/key.h"

namespace peis::cli {
namespace {

using conventions::kActuatorStatus;
using conventions::kCauseNames;
using conventions::kComponentName;
using conventions::kComponentOutputs;
using conventions::kCurrState;
using conventions::kFunctionalities;
using conventions::kMetaInputPrefix;
using conventions::kReqState;
using conventions::kStatus;

std::vector<PeisId> idsOf(const std::string& text) {
  std::vector<PeisId> ids;
  for (const auto& word : words(text)) {
    if (auto id = parsePeisId(word)) ids.push_back(*id);
  }
  return ids;
}

bool endsWith(std::string_view text, std::string_view suffix) {
  return text.size() > suffix.size() && text.substr(text.size() - suffix.size()) == suffix;
}

// "11 (sensor)", or "11" when the name is not known.
std::string withName(PeisId id, const NameOf& nameOf) {
  const auto name = nameOf(id);
  return std::to_string(id) + (name.empty() ? "" : " (" + name + ")");
}

std::string idList(const std::vector<PeisId>& ids, const NameOf& nameOf) {
  if (ids.empty()) return "-";
  std::string text;
  for (auto id : ids) text += (text.empty() ? "" : ", ") + withName(id, nameOf);
  return text;
}

std::string jsonIds(const std::vector<PeisId>& ids) {
  std::string text = "[";
  for (std::size_t i = 0; i < ids.size(); ++i) text += (i ? "," : "") + std::to_string(ids[i]);
  return text + "]";
}

std::string jsonStrings(const std::vector<std::string>& items) {
  std::string text = "[";
  for (std::size_t i = 0; i < items.size(); ++i) text += (i ? "," : "") + json::quote(items[i]);
  return text + "]";
}

}  // namespace

PeisInfo collectInfo(PeisId id, const std::vector<Tuple>& tuples, Timestamp now) {
  PeisInfo info;
  info.id = id;
  std::map<std::string, std::string> values;
  for (const auto& t : tuples) {
    if (t.owner == id) values[t.key] = t.data;
  }
  auto value = [&](std::string_view key) {
    auto it = values.find(std::string(key));
    return it == values.end() ? std::string() : it->second;
  };
  info.name = value("kernel.name");
  info.host = value("kernel.hostname");
  info.user = value("kernel.user");
  info.version = value("kernel.version");
  info.port = value("kernel.port");
  try {
    info.upSeconds =
        static_cast<double>(now.time_since_epoch().count() - std::stoll(value("kernel.started"))) /
        1e6;
  } catch (const std::exception&) {
  }
  info.links = idsOf(value("kernel.links"));
  info.subscribers = idsOf(value("kernel.subscribers"));
  info.component = value(kComponentName);
  info.status = value(kStatus);
  info.causes = value(kCauseNames);
  info.outputs = words(value(kComponentOutputs));
  info.functionalities = words(value(kFunctionalities));
  const auto missing = words(info.causes);
  std::map<std::string, ActuatorInfo> actuators;
  for (const auto& [key, data] : values) {
    if (key.rfind(kMetaInputPrefix, 0) == 0 && key.size() > kMetaInputPrefix.size()) {
      InputInfo input;
      input.name = key.substr(kMetaInputPrefix.size());
      input.target = data;
      if (const auto dot = data.find('.'); dot != std::string::npos) {
        input.targetOwner = parsePeisId(std::string_view(data).substr(0, dot));
      }
      input.missing = info.status == conventions::kWaiting &&
                      std::find(missing.begin(), missing.end(), input.name) != missing.end();
      info.inputs.push_back(std::move(input));
    }
    for (auto suffix : {kReqState, kCurrState, kActuatorStatus}) {
      if (!endsWith(key, suffix)) continue;
      const auto name = key.substr(0, key.size() - suffix.size());
      // <act>.status is only an actuator's when it has a currState too.
      if (suffix == kActuatorStatus && !values.count(name + std::string(kCurrState))) continue;
      auto& actuator = actuators[name];
      actuator.name = name;
      (suffix == kReqState    ? actuator.reqState
       : suffix == kCurrState ? actuator.currState
                              : actuator.status) = data;
    }
  }
  for (auto& [name, actuator] : actuators) info.actuators.push_back(std::move(actuator));
  return info;
}

std::string formatInfo(const PeisInfo& info, const NameOf& nameOf) {
  std::ostringstream out;
  out << "PEIS " << info.id << " '" << info.name << "'";
  if (!info.host.empty()) out << " on " << info.host;
  if (!info.user.empty()) out << ", user " << info.user;
  if (!info.version.empty()) out << ", kernel " << info.version;
  out << ", up " << seconds(info.upSeconds);
  if (!info.port.empty()) out << ", port " << info.port;
  out << "\n  links        " << idList(info.links, nameOf) << "\n";
  out << "  subscribers  " << idList(info.subscribers, nameOf) << "\n";
  if (info.component.empty() && info.status.empty()) {
    out << "no component\n";
  } else {
    out << "component " << (info.component.empty() ? "?" : info.component) << ": "
        << (info.status.empty() ? "?" : info.status);
    if (!info.causes.empty()) out << " (" << info.causes << ")";
    out << "\n";
  }
  if (!info.inputs.empty()) {
    out << "  inputs\n";
    for (const auto& input : info.inputs) {
      out << "    " << input.name << " <- ";
      if (input.target.empty()) {
        out << "(nowhere)";
      } else {
        out << input.target;
        if (input.targetOwner) {
          const auto name = nameOf(*input.targetOwner);
          if (!name.empty()) out << " (" << name << ")";
        }
      }
      if (input.missing) out << "  [missing or stale]";
      out << "\n";
    }
  }
  if (!info.outputs.empty()) {
    out << "  outputs";
    for (const auto& output : info.outputs) out << " " << output;
    out << "\n";
  }
  if (!info.actuators.empty()) {
    out << "  actuators\n";
    for (const auto& a : info.actuators) {
      out << "    " << a.name << ": reqState " << (a.reqState.empty() ? "-" : a.reqState)
          << ", currState " << (a.currState.empty() ? "-" : a.currState) << ", status "
          << (a.status.empty() ? "-" : a.status) << "\n";
    }
  }
  if (!info.functionalities.empty()) {
    out << "  functionalities";
    for (const auto& f : info.functionalities) out << " " << f;
    out << "\n";
  }
  return out.str();
}

std::string infoJson(const PeisInfo& info) {
  std::ostringstream out;
  out << "{\"id\":" << info.id << ",\"name\":" << json::quote(info.name)
      << ",\"host\":" << json::quote(info.host) << ",\"user\":" << json::quote(info.user)
      << ",\"version\":" << json::quote(info.version) << ",\"port\":" << json::quote(info.port)
      << ",\"uptime_s\":" << info.upSeconds << ",\"links\":" << jsonIds(info.links)
      << ",\"subscribers\":" << jsonIds(info.subscribers)
      << ",\"component\":" << json::quote(info.component)
      << ",\"status\":" << json::quote(info.status) << ",\"causes\":" << json::quote(info.causes)
      << ",\"inputs\":[";
  for (std::size_t i = 0; i < info.inputs.size(); ++i) {
    const auto& input = info.inputs[i];
    out << (i ? "," : "") << "{\"name\":" << json::quote(input.name)
        << ",\"target\":" << json::quote(input.target)
        << ",\"missing\":" << (input.missing ? "true" : "false") << "}";
  }
  out << "],\"outputs\":" << jsonStrings(info.outputs) << ",\"actuators\":[";
  for (std::size_t i = 0; i < info.actuators.size(); ++i) {
    const auto& a = info.actuators[i];
    out << (i ? "," : "") << "{\"name\":" << json::quote(a.name)
        << ",\"reqState\":" << json::quote(a.reqState)
        << ",\"currState\":" << json::quote(a.currState) << ",\"status\":" << json::quote(a.status)
        << "}";
  }
  out << "],\"functionalities\":" << jsonStrings(info.functionalities) << "}";
  return out.str();
}

}  // namespace peis::cli
