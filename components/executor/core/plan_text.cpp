// Plans and static links as text (see plan_text.h).
#include "plan_text.h"

#include <cctype>
#include <stdexcept>

namespace peis::executor {

namespace {

std::string trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return std::string(s);
}

std::vector<std::string> split(std::string_view text, char separator) {
  std::vector<std::string> parts;
  for (;;) {
    const auto at = text.find(separator);
    parts.push_back(trim(text.substr(0, at)));
    if (at == std::string_view::npos) return parts;
    text.remove_prefix(at + 1);
  }
}

// "PEIS.KEY" -> (PEIS, KEY) at the first dot; both non-empty.
bool splitOwnerKey(std::string_view text, std::string& owner, std::string& key) {
  const auto dot = text.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == text.size()) return false;
  owner = trim(text.substr(0, dot));
  key = trim(text.substr(dot + 1));
  return !owner.empty() && !key.empty() && key.find(' ') == std::string::npos;
}

}  // namespace

std::vector<PlanStep> parsePlan(std::string_view text) {
  std::vector<PlanStep> plan;
  if (trim(text).empty()) return plan;
  for (const std::string& stepText : split(text, ';')) {
    const auto parts = split(stepText, '|');
    std::string problem;
    const auto action = exec::parseAction(parts[0], &problem);
    if (!action) throw std::invalid_argument("plan step '" + stepText + "': " + problem);
    PlanStep step{action->name, action->args, {}};
    for (std::size_t i = 1; i < parts.size(); ++i) {
      if (!parseNeed(parts[i]))
        throw std::invalid_argument("plan step '" + stepText + "': need '" + parts[i] +
                                    "' is not INFORMATION@PEIS.KEY");
      step.needs.push_back(parts[i]);
    }
    plan.push_back(std::move(step));
  }
  return plan;
}

std::string formatPlan(const std::vector<PlanStep>& plan) {
  std::string out;
  for (const auto& step : plan) {
    if (!out.empty()) out += "; ";
    out += step.toString();
    for (const auto& need : step.needs) out += " | " + need;
  }
  return out;
}

std::optional<NeedParts> parseNeed(std::string_view need) {
  const auto at = need.rfind('@');
  if (at == std::string_view::npos || at == 0) return std::nullopt;
  NeedParts parts;
  parts.information = trim(need.substr(0, at));
  if (parts.information.empty() || !splitOwnerKey(need.substr(at + 1), parts.consumer, parts.key))
    return std::nullopt;
  return parts;
}

StaticLink parseStaticLink(std::string_view text) {
  const auto eq = text.find('=');
  StaticLink link;
  if (eq == std::string_view::npos || eq == 0 ||
      !splitOwnerKey(text.substr(eq + 1), link.producer, link.key))
    throw std::invalid_argument(
        "link '" + std::string(text) +
        "': expected INFORMATION=PEIS.KEY, e.g. position(pippi)=tracker.position.Pippi");
  link.information = trim(text.substr(0, eq));
  return link;
}

}  // namespace peis::executor
