// Evaluating success conditions and narration tests on a tuple's value:
// select the part looked at (a line by its first words, a field), then test
// it (equals, matches, above, below, near a point or a tuple's position,
// present). Pure functions, unit-tested without a network.
#pragma once

#include <optional>
#include <string>
#include <utility>

#include "scenario.h"

namespace peis::scenario {

// The selected part of `data`: with `line`, the rest of the first line
// whose leading words are `line` (nullopt if none); with `field`, that
// whitespace-separated word of the (selected) text (nullopt if too few).
std::optional<std::string> selectPart(const Selector& selector, const std::string& data);

// The first two numbers of a text (`6.6 4.9 0` or `X Y VXX …`).
std::optional<std::pair<double, double>> firstTwoNumbers(const std::string& text);

struct Verdict {
  bool held = false;
  std::string detail;  // what was seen: "41.2 is not above 90", "0.08 m from (6.600, 4.900)"
};

// Tests `selected`. `nearTarget`: for a Near test with a tuple, that tuple's
// position when known.
Verdict evaluate(const Test& test, const std::optional<std::string>& selected,
                 const std::optional<std::pair<double, double>>& nearTarget = std::nullopt);

// "above 90", "near (6.6, 4.9) within 0.15", for messages.
std::string describe(const Test& test);

}  // namespace peis::scenario
