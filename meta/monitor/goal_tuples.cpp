// Goal tuples and the configurator's answers to them, as text.
#include "monitor/goal_tuples.h"

#include <charconv>
#include <sstream>

#include "peis/error.h"

namespace peis::meta {
namespace {

std::string_view trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

// Goals::fromArguments prefixes its messages with "argument 1: "; the tuple
// line says where instead.
std::string withoutArgumentPrefix(const std::string& message) {
  const std::string prefix = "argument 1: ";
  const auto at = message.find(prefix);
  return at == std::string::npos ? message : message.substr(at + prefix.size());
}

}  // namespace

void mergeGoals(Goals& goals, const Goals& more) {
  goals.information.insert(goals.information.end(), more.information.begin(),
                           more.information.end());
  goals.run.insert(goals.run.end(), more.run.begin(), more.run.end());
  auto& c = goals.constraints;
  const auto& m = more.constraints;
  c.avoidPeis.insert(c.avoidPeis.end(), m.avoidPeis.begin(), m.avoidPeis.end());
  c.avoidPeisOrigin.insert(m.avoidPeisOrigin.begin(), m.avoidPeisOrigin.end());
  c.avoid.insert(c.avoid.end(), m.avoid.begin(), m.avoid.end());
  c.prefer.insert(c.prefer.end(), m.prefer.begin(), m.prefer.end());
}

ParsedGoalTuple parseGoalTuple(std::string_view text, const std::string& origin) {
  ParsedGoalTuple parsed;
  std::istringstream in{std::string(text)};
  std::size_t number = 0;
  for (std::string raw; std::getline(in, raw);) {
    ++number;
    const auto line = trim(raw);
    if (line.empty() || line.front() == '#') continue;
    const auto where = origin + ":" + std::to_string(number);
    try {
      auto goals = Goals::fromArguments({std::string(line)});
      for (auto& g : goals.information) g.origin = where;
      for (auto& g : goals.run) g.origin = where;
      for (auto& [name, at] : goals.constraints.avoidPeisOrigin) at = where;
      mergeGoals(parsed.goals, goals);
    } catch (const Error& e) {
      parsed.problems.push_back(where + ": " + withoutArgumentPrefix(e.what()));
    }
  }
  return parsed;
}

std::string formatGoalTuple(const std::vector<std::string>& goals) {
  std::string text;
  for (const auto& g : goals) text += g + "\n";
  return text;
}

const char* toString(GoalState state) {
  switch (state) {
    case GoalState::Deployed:
      return "deployed";
    case GoalState::Pending:
      return "pending";
    case GoalState::Infeasible:
      return "infeasible";
    case GoalState::Refused:
      return "refused";
  }
  return "?";
}

std::string GoalStatusLine::format() const {
  std::string line =
      std::to_string(owner) + "." + key + " " + std::to_string(seqno) + " " + meta::toString(state);
  if (!reason.empty()) {
    std::string oneLine;
    for (char c : reason) oneLine += c == '\n' ? ' ' : c;
    line += ": " + oneLine;
  }
  return line;
}

std::optional<GoalStatusLine> GoalStatusLine::parse(std::string_view line) {
  GoalStatusLine s;
  const auto space1 = line.find(' ');
  if (space1 == std::string_view::npos) return std::nullopt;
  const auto target = line.substr(0, space1);
  const auto dot = target.find('.');
  if (dot == std::string_view::npos) return std::nullopt;
  if (std::from_chars(target.data(), target.data() + dot, s.owner).ptr != target.data() + dot)
    return std::nullopt;
  s.key = std::string(target.substr(dot + 1));
  auto rest = line.substr(space1 + 1);
  const auto space2 = rest.find(' ');
  if (space2 == std::string_view::npos) return std::nullopt;
  if (std::from_chars(rest.data(), rest.data() + space2, s.seqno).ptr != rest.data() + space2)
    return std::nullopt;
  rest = rest.substr(space2 + 1);
  const auto colon = rest.find(": ");
  const auto state = rest.substr(0, colon);
  if (colon != std::string_view::npos) s.reason = std::string(rest.substr(colon + 2));
  bool known = false;
  for (auto candidate :
       {GoalState::Deployed, GoalState::Pending, GoalState::Infeasible, GoalState::Refused}) {
    if (state == meta::toString(candidate)) {
      s.state = candidate;
      known = true;
    }
  }
  if (!known) return std::nullopt;
  return s;
}

std::string formatGoalStatus(const std::vector<GoalStatusLine>& lines) {
  std::string text;
  for (const auto& l : lines) text += l.format() + "\n";
  return text;
}

std::vector<GoalStatusLine> parseGoalStatus(std::string_view text) {
  std::vector<GoalStatusLine> lines;
  std::istringstream in{std::string(text)};
  for (std::string line; std::getline(in, line);) {
    if (auto parsed = GoalStatusLine::parse(line)) lines.push_back(*parsed);
  }
  return lines;
}

}  // namespace peis::meta
