// The table of built-in `peis` commands; see command.h.
#include <iostream>

#include "command.h"
#include "lookup.h"

namespace peis::cli {

const std::vector<Command>& builtinCommands() {
  static const std::vector<Command> commands{
      lsCommand(),   infoCommand(),  getCommand(), setCommand(),    appendCommand(), eraseCommand(),
      metaCommand(), watchCommand(), hzCommand(),  tuplesCommand(), nodeCommand(),   keysCommand(),
  };
  return commands;
}

const Command* findBuiltin(const std::string& name) {
  for (const auto& command : builtinCommands()) {
    if (command.name == name) return &command;
  }
  return nullptr;
}

void expectArguments(const Args& args, std::size_t min, std::size_t max, const std::string& what) {
  if (args.positional.size() < min || args.positional.size() > max) {
    throw UsageError(args.command + " needs " + what);
  }
}

WriteRequest readWriteRequest(Kernel& kernel, const Args& args) {
  expectArguments(args, 2, 2, "OWNER.KEY VALUE");
  const auto name = parseFullName(args.positional[0]);
  auto value = readValue(args.positional[1], args.has("--literal"), std::cin);
  const auto deadline = deadlineIn(args.seconds("--timeout").value_or(5.0));
  return {reachableOwner(kernel, name.owner, deadline), name.key, std::move(value)};
}

bool runUntilQuitOrTimeout(Kernel& kernel, const Args& args) {
  if (auto timeout = args.seconds("--timeout")) {
    return kernel.runFor(std::chrono::milliseconds(static_cast<long long>(*timeout * 1000)));
  }
  kernel.run();
  return true;
}

}  // namespace peis::cli
