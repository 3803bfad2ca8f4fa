// peis tuples: the current tuples of the ecology that match a pattern.
#include <algorithm>
#include <iostream>

#include "command.h"
#include "lookup.h"
#include "output.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 0, 1, "at most one PATTERN");
  const auto deadline = deadlineIn(args.seconds("--wait").value_or(3.0));
  settle(kernel, deadline);
  const auto pattern =
      patternOf(kernel, args.positional.empty() ? "*.**" : args.positional[0], deadline);
  if (!fetchMatching(kernel, pattern, deadline)) {
    std::cerr << "peis: some tuples did not arrive in time\n";
  }
  auto tuples = kernel.find(pattern);
  tuples.erase(std::remove_if(tuples.begin(), tuples.end(),
                              [&](const Tuple& t) { return t.owner == kernel.id(); }),
               tuples.end());
  if (args.has("--json")) {
    std::cout << "[";
    for (std::size_t i = 0; i < tuples.size(); ++i) {
      std::cout << (i ? "," : "") << tupleJson(tuples[i]);
    }
    std::cout << "]\n";
  } else {
    for (const auto& t : tuples) std::cout << tupleLine(t) << "\n";
  }
  return 0;
}

}  // namespace

Command tuplesCommand() {
  return {"tuples",
          "tuples [PATTERN]",
          "the current tuples of the ecology that match (default *.**)",
          "Waits until the membership settled, then until every matching key that\n"
          "each PEIS lists in its kernel.all-keys has arrived (at most --wait, 3 s),\n"
          "and prints 'OWNER.KEY = VALUE' ordered by owner id, then key.",
          {"--wait", "--json"},
          true,
          run};
}

}  // namespace peis::cli
