// The success conditions of a run; see condition_tracker.h.
#include "condition_tracker.h"

#include "condition.h"

namespace peis::scenario {

ConditionTracker::ConditionTracker(std::vector<Condition> conditions,
                                   std::optional<double> defaultDeadline)
    : conditions_(std::move(conditions)), defaultDeadline_(defaultDeadline) {
  for (const auto& c : conditions_) states_.push_back(State{&c, false, std::nullopt, "no value", c.after.empty()});
}

double ConditionTracker::deadline(const Condition& c) const {
  return c.by.value_or(defaultDeadline_.value_or(0));
}

std::vector<ConditionTracker::Held> ConditionTracker::test(std::size_t i, double now) {
  State& s = states_[i];
  if (s.held || !s.armed || !started_) return {};
  const Condition& c = *s.condition;
  const auto value = values_.find({c.owner, c.key});
  const std::optional<std::string> data =
      value == values_.end() ? std::nullopt : value->second;
  std::optional<std::pair<double, double>> target;
  if (c.test.kind == TestKind::Near && !c.test.nearOwner.empty()) {
    const auto t = values_.find({c.test.nearOwner, c.test.nearKey});
    if (t != values_.end() && t->second) target = firstTwoNumbers(*t->second);
  }
  const auto selected = data ? selectPart(c.select, *data) : std::nullopt;
  const Verdict v = evaluate(c.test, selected, target);
  s.detail = v.detail;
  if (!v.held) return {};
  s.held = true;
  s.at = now;
  return {Held{c.name, now, v.detail}};
}

std::vector<ConditionTracker::Held> ConditionTracker::cascade(std::vector<Held> held, double now) {
  // Conditions that come after one that now holds are armed and tested.
  for (std::size_t k = 0; k < held.size(); ++k) {
    for (std::size_t i = 0; i < states_.size(); ++i) {
      if (states_[i].armed || states_[i].condition->after != held[k].name) continue;
      states_[i].armed = true;
      for (auto& h : test(i, now)) held.push_back(std::move(h));
    }
  }
  return held;
}

std::vector<ConditionTracker::Held> ConditionTracker::value(const std::string& owner,
                                                            const std::string& key,
                                                            const std::optional<std::string>& data,
                                                            double now) {
  values_[{owner, key}] = data;
  std::vector<Held> held;
  for (std::size_t i = 0; i < states_.size(); ++i) {
    const Condition& c = *states_[i].condition;
    const bool looks = (c.owner == owner && c.key == key) ||
                       (c.test.nearOwner == owner && c.test.nearKey == key);
    if (!looks) continue;
    for (auto& h : test(i, now)) held.push_back(std::move(h));
  }
  return cascade(std::move(held), now);
}

std::vector<ConditionTracker::Held> ConditionTracker::start(double now) {
  started_ = true;
  std::vector<Held> held;
  for (std::size_t i = 0; i < states_.size(); ++i) {
    for (auto& h : test(i, now)) held.push_back(std::move(h));
  }
  return cascade(std::move(held), now);
}

const Condition* ConditionTracker::overdue(double now) const {
  for (const auto& s : states_) {
    if (!s.held && now > deadline(*s.condition)) return s.condition;
  }
  return nullptr;
}

bool ConditionTracker::allHeld() const {
  for (const auto& s : states_) {
    if (!s.held) return false;
  }
  return true;
}

}  // namespace peis::scenario
