// peis get: one tuple's value.
#include <iostream>

#include "command.h"
#include "lookup.h"
#include "output.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 1, 1, "OWNER.KEY");
  const auto name = parseFullName(args.positional[0]);
  const auto deadline = deadlineIn(args.seconds("--wait").value_or(2.0));
  const auto owner = resolvePeis(kernel, name.owner, deadline);
  if (owner != kernel.id()) kernel.subscribe(Pattern::exact(owner, special::kAllKeys));
  auto tuple = kernel.get(owner, name.key, timeLeft(deadline));
  if (!tuple) {
    if (!reachable(kernel, owner)) {
      std::cerr << "peis: " << fullName(owner, name.key) << " has no value (PEIS " << owner
                << " not reachable)\n";
    } else if (auto message = missingKeyMessage(kernel, owner, name.key, deadlineIn(1.0))) {
      std::cerr << "peis: " << *message << "\n";
    } else {
      std::cerr << "peis: " << fullName(owner, name.key) << " has no value\n";
    }
    return 1;
  }
  if (args.has("--raw")) {
    std::cout << tuple->data << std::flush;
  } else {
    std::cout << (args.has("--json") ? tupleJson(*tuple) : printable(*tuple)) << "\n";
  }
  return 0;
}

}  // namespace

Command getCommand() {
  return {"get",
          "get OWNER.KEY",
          "print a tuple's value; exit 1 if absent at the deadline",
          "Prints the data and a newline (binary data as <N bytes>, all of it with\n"
          "--raw) as soon as the tuple has a value, at most --wait (2 s). A key the\n"
          "owner does not have is answered with its closest keys.",
          {"--wait", "--json", "--raw"},
          true,
          run};
}

}  // namespace peis::cli
