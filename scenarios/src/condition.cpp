// Evaluating conditions; see condition.h.
#include "condition.h"

#include <cmath>
#include <cstdio>
#include <regex>
#include <sstream>
#include <vector>

namespace peis::scenario {
namespace {

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

std::optional<double> toNumber(const std::string& text) {
  const auto w = words(text);
  if (w.size() != 1) return std::nullopt;
  std::size_t used = 0;
  try {
    const double v = std::stod(w[0], &used);
    if (used == w[0].size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

std::string shorten(const std::string& text) {
  constexpr std::size_t kMax = 60;
  std::string one = text;
  for (char& c : one) {
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  }
  return one.size() > kMax ? one.substr(0, kMax) + "…" : one;
}

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace

std::optional<std::string> selectPart(const Selector& selector, const std::string& data) {
  std::optional<std::string> text = data;
  if (!selector.line.empty()) {
    text.reset();
    const auto prefix = words(selector.line);
    std::istringstream lines(data);
    for (std::string line; std::getline(lines, line);) {
      const auto w = words(line);
      if (w.size() < prefix.size() || !std::equal(prefix.begin(), prefix.end(), w.begin()))
        continue;
      std::string rest;
      for (std::size_t i = prefix.size(); i < w.size(); ++i)
        rest += (rest.empty() ? "" : " ") + w[i];
      text = rest;
      break;
    }
  }
  if (text && selector.field) {
    const auto w = words(*text);
    const auto index = static_cast<std::size_t>(*selector.field);
    if (index < 1 || index > w.size()) return std::nullopt;
    return w[index - 1];
  }
  return text;
}

std::optional<std::pair<double, double>> firstTwoNumbers(const std::string& text) {
  const auto w = words(text);
  if (w.size() < 2) return std::nullopt;
  const auto x = toNumber(w[0]), y = toNumber(w[1]);
  if (!x || !y) return std::nullopt;
  return std::pair{*x, *y};
}

Verdict evaluate(const Test& test, const std::optional<std::string>& selected,
                 const std::optional<std::pair<double, double>>& nearTarget) {
  if (!selected) return {false, "no value"};
  const std::string& s = *selected;
  switch (test.kind) {
    case TestKind::Present:
    case TestKind::Changes:  // the tracker calls it only for a new value
      return {true, "'" + shorten(s) + "'"};
    case TestKind::Equals:
      return {s == test.text, "'" + shorten(s) + "'"};
    case TestKind::Matches:
      return {std::regex_search(s, std::regex(test.text)), "'" + shorten(s) + "'"};
    case TestKind::Above:
    case TestKind::Below: {
      const auto v = toNumber(s);
      if (!v) return {false, "'" + shorten(s) + "' is not a number"};
      const bool above = test.kind == TestKind::Above;
      const bool held = above ? *v > test.number : *v < test.number;
      std::ostringstream bound;
      bound << test.number;
      return {held, shorten(s) + (held ? " is " : " is not ") + (above ? "above " : "below ") +
                        bound.str()};
    }
    case TestKind::Near: {
      std::optional<std::pair<double, double>> target;
      if (test.x && test.y) target = std::pair{*test.x, *test.y};
      if (!test.nearOwner.empty()) target = nearTarget;
      if (!target) return {false, "no position of " + test.nearOwner + "." + test.nearKey + " yet"};
      const auto here = firstTwoNumbers(s);
      if (!here) return {false, "'" + shorten(s) + "' is not a position"};
      const double d = std::hypot(here->first - target->first, here->second - target->second);
      return {d <= test.number, fixed(d, 3) + " m from (" + fixed(target->first, 3) + ", " +
                                    fixed(target->second, 3) + ")"};
    }
  }
  return {false, "?"};
}

std::string describe(const Test& test) {
  std::ostringstream out;
  switch (test.kind) {
    case TestKind::Present:
      out << "present";
      break;
    case TestKind::Changes:
      out << "changing";
      break;
    case TestKind::Equals:
      out << "equal to '" << test.text << "'";
      break;
    case TestKind::Matches:
      out << "matching /" << test.text << "/";
      break;
    case TestKind::Above:
      out << "above " << test.number;
      break;
    case TestKind::Below:
      out << "below " << test.number;
      break;
    case TestKind::Near:
      if (test.x && test.y)
        out << "within " << test.number << " m of (" << *test.x << ", " << *test.y << ")";
      else
        out << "within " << test.number << " m of " << test.nearOwner << "." << test.nearKey;
      break;
  }
  return out.str();
}

}  // namespace peis::scenario
