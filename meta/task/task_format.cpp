// Text and JSON forms of a task plan (the `peis plan` output).
#include <cstdio>

#include "peis/meta/task.h"
#include "planner/json.h"

namespace peis::meta::task {

std::string Step::toString() const {
  std::string text = action + "(";
  for (std::size_t i = 0; i < arguments.size(); ++i) text += (i ? ", " : "") + arguments[i];
  return text + ")";
}

std::string formatText(const TaskPlan& plan) {
  char buf[64];
  if (!plan.found) {
    return plan.reason + " (" + std::to_string(plan.statesExpanded) + " states searched)\n";
  }
  std::snprintf(buf, sizeof buf, "%g", plan.cost);
  std::string out = "plan, cost " + std::string(buf) + (plan.optimal ? " (optimal)" : "") + ", " +
                    std::to_string(plan.statesExpanded) + " states searched:\n";
  for (std::size_t i = 0; i < plan.steps.size(); ++i) {
    out += "  " + std::to_string(i + 1) + ". " + plan.steps[i].toString();
    if (!plan.steps[i].needs.empty()) {
      out += "  needs";
      for (const auto& n : plan.steps[i].needs) out += " " + n;
    }
    out += "\n";
  }
  return out;
}

std::string formatJson(const TaskPlan& plan) {
  using json::number;
  using json::quote;
  std::string out = "{\"found\":" + std::string(plan.found ? "true" : "false") +
                    ",\"optimal\":" + (plan.optimal ? "true" : "false") +
                    ",\"cost\":" + number(plan.found ? plan.cost : NAN) + ",\"steps\":[";
  for (std::size_t i = 0; i < plan.steps.size(); ++i) {
    const auto& s = plan.steps[i];
    out += std::string(i ? "," : "") + "{\"action\":" + quote(s.action) + ",\"arguments\":[";
    for (std::size_t a = 0; a < s.arguments.size(); ++a)
      out += (a ? "," : "") + quote(s.arguments[a]);
    out += "],\"cost\":" + number(s.cost) + ",\"needs\":[";
    for (std::size_t n = 0; n < s.needs.size(); ++n) out += (n ? "," : "") + quote(s.needs[n]);
    out += "]}";
  }
  out += "],\"statesExpanded\":" + std::to_string(plan.statesExpanded) +
         ",\"statesGenerated\":" + std::to_string(plan.statesGenerated) +
         ",\"groundActions\":" + std::to_string(plan.groundActions) +
         ",\"milliseconds\":" + number(plan.milliseconds) + ",\"reason\":" + quote(plan.reason) +
         "}";
  return out;
}

}  // namespace peis::meta::task
