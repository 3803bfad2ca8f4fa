// peis erase: delete a tuple of any PEIS.
#include <iostream>

#include "command.h"
#include "lookup.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 1, 1, "OWNER.KEY");
  const auto name = parseFullName(args.positional[0]);
  const auto deadline = deadlineIn(args.seconds("--timeout").value_or(5.0));
  const auto owner = reachableOwner(kernel, name.owner, deadline);
  if (owner != kernel.id()) kernel.subscribe(Pattern::exact(owner, special::kAllKeys));
  if (!kernel.erase(owner, name.key)) {
    const auto message = missingKeyMessage(kernel, owner, name.key, deadlineIn(1.0));
    std::cerr << "peis: "
              << message.value_or("no key '" + name.key + "' at PEIS " +
                                  describePeis(kernel, owner))
              << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

Command eraseCommand() {
  return {"erase",
          "erase OWNER.KEY",
          "delete a tuple; exit 1 if there was none",
          "The owner deletes the tuple; its subscribers see the deletion. A key the\n"
          "owner does not have is answered with its closest keys (exit 1).",
          {"--timeout"},
          true,
          run};
}

}  // namespace peis::cli
