// ExecGoal / ExecStatus texts: parsing and formatting, every field checked.
#include "exec_protocol.h"

#include <cctype>
#include <cmath>
#include <cstdlib>

namespace peis::exec {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool validWord(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isspace(u) || c == '(' || c == ')' || c == ',' || !std::isprint(u)) return false;
  }
  return true;
}

bool fail(std::string* problem, std::string why) {
  if (problem) *problem = std::move(why);
  return false;
}

}  // namespace

std::string Action::toString() const {
  if (args.empty()) return name;
  std::string out = name + "(";
  for (std::size_t i = 0; i < args.size(); ++i) out += (i ? ", " : "") + args[i];
  return out + ")";
}

std::optional<Action> parseAction(std::string_view text, std::string* problem) {
  text = trim(text);
  if (text.empty()) return fail(problem, "empty action"), std::nullopt;
  if (text.size() > kMaxActionBytes)
    return fail(problem, "action longer than " + std::to_string(kMaxActionBytes) + " bytes"),
           std::nullopt;
  Action action;
  const std::size_t open = text.find('(');
  if (open == std::string_view::npos) {
    action.name = std::string(text);
  } else {
    if (text.back() != ')')
      return fail(problem, "expected ')' at the end of '" + std::string(text) + "'"), std::nullopt;
    action.name = std::string(trim(text.substr(0, open)));
    std::string_view inside = text.substr(open + 1, text.size() - open - 2);
    if (!trim(inside).empty()) {
      for (;;) {
        const std::size_t comma = inside.find(',');
        const std::string_view arg = trim(inside.substr(0, comma));
        if (!validWord(arg))
          return fail(problem, "bad argument '" + std::string(arg) + "' in '" + std::string(text) +
                                   "' (arguments are words or numbers separated by commas)"),
                 std::nullopt;
        action.args.emplace_back(arg);
        if (comma == std::string_view::npos) break;
        inside.remove_prefix(comma + 1);
      }
    }
  }
  if (!validWord(action.name) || !std::isalpha(static_cast<unsigned char>(action.name[0])))
    return fail(problem, "bad action name '" + action.name + "' (expected e.g. GoTo(bed))"),
           std::nullopt;
  return action;
}

const char* toString(ExecState state) {
  switch (state) {
    case ExecState::Running:
      return "running";
    case ExecState::Success:
      return "success";
    case ExecState::Failed:
      return "failed";
  }
  return "failed";
}

std::string ExecStatus::toString() const {
  std::string out =
      std::string(exec::toString(state)) + " " + std::to_string(goalId) + " " + action;
  if (!cause.empty()) out += " " + cause;
  return out;
}

std::optional<ExecStatus> parseExecStatus(std::string_view text, std::string* problem) {
  text = trim(text);
  ExecStatus status;
  const std::size_t s1 = text.find(' ');
  const std::string_view state = text.substr(0, s1);
  if (state == "running") {
    status.state = ExecState::Running;
  } else if (state == "success") {
    status.state = ExecState::Success;
  } else if (state == "failed") {
    status.state = ExecState::Failed;
  } else {
    return fail(problem, "unknown state '" + std::string(state) + "'"), std::nullopt;
  }
  if (s1 == std::string_view::npos) return fail(problem, "no goal id"), std::nullopt;
  std::string_view rest = trim(text.substr(s1 + 1));
  const std::size_t s2 = rest.find(' ');
  const std::string id(rest.substr(0, s2));
  char* end = nullptr;
  status.goalId = std::strtoull(id.c_str(), &end, 10);
  if (id.empty() || *end != '\0' || !std::isdigit(static_cast<unsigned char>(id[0])))
    return fail(problem, "bad goal id '" + id + "'"), std::nullopt;
  if (s2 == std::string_view::npos) return fail(problem, "no action"), std::nullopt;
  rest = trim(rest.substr(s2 + 1));
  // The action ends at its closing parenthesis, or at the first space.
  std::size_t actionEnd = rest.find(' ');
  const std::size_t open = rest.find('(');
  if (open != std::string_view::npos && (actionEnd == std::string_view::npos || open < actionEnd)) {
    const std::size_t close = rest.find(')', open);
    if (close == std::string_view::npos) return fail(problem, "unclosed action"), std::nullopt;
    actionEnd = close + 1;
  }
  const auto action = parseAction(rest.substr(0, actionEnd), problem);
  if (!action) return std::nullopt;
  status.action = action->toString();
  if (actionEnd < rest.size()) status.cause = std::string(trim(rest.substr(actionEnd)));
  return status;
}

std::optional<double> parseNumber(std::string_view text) {
  const std::string s(trim(text));
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(s.c_str(), &end);
  if (*end != '\0' || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace peis::exec
