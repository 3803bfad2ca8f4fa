// peis info: one PEIS at a glance: who it is, its links and subscribers,
// its component's status, inputs (and where they point), outputs and
// actuators.
#include <iostream>

#include "command.h"
#include "info_model.h"
#include "lookup.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 1, 1, "PEIS (an id or a name)");
  const auto deadline = deadlineIn(args.seconds("--wait").value_or(3.0));
  const auto id = reachableOwner(kernel, args.positional[0], deadline);
  const auto pattern = Pattern("**", id);
  if (!fetchMatching(kernel, pattern, deadline)) {
    std::cerr << "peis: some tuples of PEIS " << id << " did not arrive in time\n";
  }
  auto info = collectInfo(id, kernel.find(pattern), systemNow());
  // This command's own PEIS links to it and subscribes: not worth listing.
  std::erase(info.links, kernel.id());
  std::erase(info.subscribers, kernel.id());
  if (args.has("--json")) {
    std::cout << infoJson(info) << "\n";
  } else {
    std::cout << formatInfo(info, [&](PeisId peer) { return nameOf(kernel, peer); });
  }
  return 0;
}

}  // namespace

Command infoCommand() {
  return {"info",
          "info PEIS",
          "one PEIS: links, subscribers, component status, inputs, outputs, actuators",
          "Fetches every tuple of the PEIS (at most --wait, 3 s) and prints who it is,\n"
          "the PEIS it links to and those subscribed to it, and, when it hosts a\n"
          "component: its status and cause, each input (mi-<name>) and the tuple it\n"
          "points at, its outputs (component.outputs), actuators and functionalities.",
          {"--wait", "--json"},
          true,
          run};
}

}  // namespace peis::cli
