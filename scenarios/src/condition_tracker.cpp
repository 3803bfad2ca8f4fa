// The success conditions of a run; see condition_tracker.h.
#include "condition_tracker.h"

#include "condition.h"

namespace peis::scenario {

ConditionTracker::ConditionTracker(std::vector<Condition> conditions,
                                   std::optional<double> defaultDeadline)
    : conditions_(std::move(conditions)), defaultDeadline_(defaultDeadline) {
  for (const auto& c : conditions_) {
    State s;
    s.condition = &c;
    s.detail = "no value";
    s.ready = c.after.empty();
    states_.push_back(std::move(s));
  }
}

double ConditionTracker::deadline(const Condition& c) const {
  return c.by.value_or(defaultDeadline_.value_or(0));
}

std::vector<ConditionTracker::Held> ConditionTracker::test(std::size_t i, double now,
                                                           bool newValue) {
  State& s = states_[i];
  if (s.held || !s.armed || !started_) return {};
  const Condition& c = *s.condition;
  if (c.test.kind == TestKind::Changes && !newValue) return {};
  const auto value = values_.find({c.owner, c.key});
  const std::optional<std::string> data = value == values_.end() ? std::nullopt : value->second;
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

std::vector<ConditionTracker::Held> ConditionTracker::arm(double now) {
  std::vector<Held> held;
  if (!started_) return held;
  for (std::size_t i = 0; i < states_.size(); ++i) {
    State& s = states_[i];
    if (s.armed || !s.ready || now < s.condition->from) continue;
    s.armed = true;
    for (auto& h : test(i, now, false)) held.push_back(std::move(h));
  }
  return held;
}

std::vector<ConditionTracker::Held> ConditionTracker::cascade(std::vector<Held> held, double now) {
  // Conditions that come after one that now holds are ready, and armed if
  // their time came.
  for (std::size_t k = 0; k < held.size(); ++k) {
    for (auto& s : states_) {
      if (s.condition->after == held[k].name) s.ready = true;
    }
    for (auto& h : arm(now)) held.push_back(std::move(h));
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
    const bool own = c.owner == owner && c.key == key;
    const bool target = c.test.nearOwner == owner && c.test.nearKey == key;
    if (!own && !target) continue;
    for (auto& h : test(i, now, own && data.has_value())) held.push_back(std::move(h));
  }
  return cascade(std::move(held), now);
}

std::vector<ConditionTracker::Held> ConditionTracker::start(double now) {
  started_ = true;
  return advance(now);
}

std::vector<ConditionTracker::Held> ConditionTracker::advance(double now) {
  return cascade(arm(now), now);
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
