// The success conditions of one run as they evolve: it is fed the values of
// the tuples they look at (as the scenario names them: `world.place.bed`)
// with the scenario time, and says which conditions come to hold, which one
// missed its deadline, and what was last seen of each. A condition is armed
// once the one it comes `after` held and its `from` time came, and is then
// tested on the current value at once — except `changes`, which waits for a
// new value. Not thread-safe (the runner holds a lock); time is passed in,
// so it is unit-tested without a clock.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "scenario.h"

namespace peis::scenario {

class ConditionTracker {
 public:
  ConditionTracker(std::vector<Condition> conditions, std::optional<double> defaultDeadline);
  ConditionTracker(const ConditionTracker&) = delete;  // states point into conditions_
  ConditionTracker& operator=(const ConditionTracker&) = delete;

  struct Held {
    std::string name;
    double at = 0;
    std::string detail;
  };
  // A tuple's value (nullopt: deleted) at scenario time `now`; returns the
  // conditions that came to hold (conditions are tested only from start()).
  std::vector<Held> value(const std::string& owner, const std::string& key,
                          const std::optional<std::string>& data, double now);
  // Scenario time 0: tests every armed condition on the values known.
  std::vector<Held> start(double now);
  // Time passes: arms (and tests) the conditions whose `from` came.
  std::vector<Held> advance(double now);

  // The first condition whose deadline passed at `now` without it holding.
  const Condition* overdue(double now) const;
  bool allHeld() const;
  // The latest deadline (for messages).
  double deadline(const Condition& c) const;

  struct State {
    const Condition* condition;
    bool held = false;
    std::optional<double> at;
    std::string detail;  // what was last seen
    bool ready = false;  // what it comes after held (or it comes after nothing)
    bool armed = false;  // ready, and its `from` came
  };
  const std::vector<State>& states() const { return states_; }
  const std::vector<Condition>& conditions() const { return conditions_; }

 private:
  std::vector<Held> test(std::size_t index, double now, bool newValue);
  std::vector<Held> arm(double now);
  std::vector<Held> cascade(std::vector<Held> held, double now);

  std::vector<Condition> conditions_;
  std::optional<double> defaultDeadline_;
  std::vector<State> states_;
  std::map<std::pair<std::string, std::string>, std::optional<std::string>> values_;
  bool started_ = false;
};

}  // namespace peis::scenario
