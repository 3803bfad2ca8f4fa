// peis node: a plain PEIS that runs until it is told to quit.
#include <iostream>

#include "command.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 0, 0, "no arguments");
  // One write per line: the kernel thread logs to stderr at the same time,
  // and scripts parse this line.
  std::cerr << ("peis node: PEIS " + std::to_string(kernel.id()) + " '" + kernel.name() +
                "' on port " + std::to_string(kernel.port()) + "\n");
  const auto reason = kernel.run();
  std::cerr << ("peis node: " + reason + "\n");
  return 0;
}

}  // namespace

Command nodeCommand() {
  return {"node",
          "node",
          "run a plain PEIS until killed or kernel.do-quit = yes",
          "Prints 'peis node: PEIS <id> '<name>' on port <port>' on stderr and runs\n"
          "until SIGINT, SIGTERM or kernel.do-quit = yes. Not a tool: `peis ls`\n"
          "lists it, and the kernel logs as for any PEIS (PEIS_LOG).",
          {},
          false,
          run};
}

}  // namespace peis::cli
