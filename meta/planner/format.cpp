// Text and JSON forms of a planning result (the `peis config plan` output).
#include <cstdio>

#include "peis/meta/planner.h"
#include "planner/json.h"

namespace peis::meta {
namespace {

std::string bindingText(const std::vector<std::pair<std::string, std::string>>& binding) {
  if (binding.empty()) return "";
  std::string text = "{";
  for (std::size_t i = 0; i < binding.size(); ++i) {
    text += (i ? "," : "") + binding[i].first + "=" + binding[i].second;
  }
  return text + "}";
}

std::string fixed(double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", value);
  return buf;
}

}  // namespace

std::string ActiveInstance::toString() const {
  return peis + "/" + component + "/" + functionality + bindingText(binding);
}

std::string Link::toString() const {
  return consumerPeis + "." + consumerKey + " <- " + producerPeis + "." + producerKey;
}

std::string formatText(const PlanResult& r) {
  std::string out;
  if (!r.ok()) {
    out += r.status == PlanStatus::Infeasible ? "no configuration:\n"
                                              : "no configuration found before the deadline\n";
    for (const auto& line : r.explanation) out += "  " + line + "\n";
    return out;
  }
  out += "configuration, cost " + fixed(r.configuration.cost) + " (" + toString(r.status);
  if (r.status == PlanStatus::Feasible) {
    out += ", lower bound " + fixed(r.lowerBound) + ", gap " + fixed(100 * r.gap()) + " %";
  }
  out += ")\n";
  out += "activate:\n";
  for (const auto& i : r.configuration.instances) {
    out += "  " + i.toString() + "  cost " + fixed(i.cost);
    if (!i.activation.empty()) out += "  (" + i.activation + ".reqState)";
    out += "\n";
  }
  if (!r.configuration.links.empty()) out += "links:\n";
  for (const auto& l : r.configuration.links) {
    out += "  " + l.toString() + "  " + l.information.toString() + ", " + toString(l.kind) + " " +
           fixed(l.cost) + "\n";
  }
  return out;
}

std::string formatJson(const PlanResult& r) {
  using json::number;
  using json::quote;
  std::string out = "{\"status\":" + quote(toString(r.status));
  out += ",\"cost\":" + number(r.ok() ? r.configuration.cost : NAN);
  out += ",\"lowerBound\":" + number(r.lowerBound);
  out += ",\"gap\":" + number(r.gap());
  out += ",\"instances\":[";
  for (std::size_t k = 0; k < r.configuration.instances.size(); ++k) {
    const auto& i = r.configuration.instances[k];
    out += std::string(k ? "," : "") + "{\"peis\":" + quote(i.peis) +
           ",\"peisId\":" + std::to_string(i.peisId) + ",\"component\":" + quote(i.component) +
           ",\"functionality\":" + quote(i.functionality) + ",\"binding\":{";
    for (std::size_t b = 0; b < i.binding.size(); ++b) {
      out +=
          std::string(b ? "," : "") + quote(i.binding[b].first) + ":" + quote(i.binding[b].second);
    }
    out += "},\"activation\":" + quote(i.activation) + ",\"cost\":" + number(i.cost) + "}";
  }
  out += "],\"links\":[";
  for (std::size_t k = 0; k < r.configuration.links.size(); ++k) {
    const auto& l = r.configuration.links[k];
    out += std::string(k ? "," : "") + "{\"consumerPeis\":" + quote(l.consumerPeis) +
           ",\"consumerId\":" + std::to_string(l.consumerId) +
           ",\"consumerKey\":" + quote(l.consumerKey) +
           ",\"producerPeis\":" + quote(l.producerPeis) +
           ",\"producerId\":" + std::to_string(l.producerId) +
           ",\"producerKey\":" + quote(l.producerKey) +
           ",\"information\":" + quote(l.information.toString()) +
           ",\"kind\":" + quote(toString(l.kind)) + ",\"cost\":" + number(l.cost) + "}";
  }
  out += "],\"explanation\":[";
  for (std::size_t k = 0; k < r.explanation.size(); ++k) {
    out += std::string(k ? "," : "") + quote(r.explanation[k]);
  }
  out += "],\"stats\":{\"groundInstances\":" + std::to_string(r.stats.groundInstances) +
         ",\"relevantInstances\":" + std::to_string(r.stats.relevantInstances) +
         ",\"parts\":" + std::to_string(r.stats.parts) +
         ",\"nodes\":" + std::to_string(r.stats.nodes) +
         ",\"firstSolutionMs\":" + number(r.stats.firstSolutionMs) +
         ",\"totalMs\":" + number(r.stats.totalMs) + "}}";
  return out;
}

}  // namespace peis::meta
