// The table of built-in `peis` commands; see command.h.
#include "command.h"

namespace peis::cli {

const std::vector<Command>& builtinCommands() {
  static const std::vector<Command> commands{
      lsCommand(),   infoCommand(),  getCommand(), setCommand(),    appendCommand(), eraseCommand(),
      metaCommand(), watchCommand(), hzCommand(),  tuplesCommand(), nodeCommand(),
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

}  // namespace peis::cli
