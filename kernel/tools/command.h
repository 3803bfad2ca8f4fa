// One built-in `peis` command: its name, usage, help, the options it takes
// and the function that runs it on the command's own short-lived PEIS. Each
// command lives in its own cmd_<name>.cpp; commands.cpp lists them.
#pragma once

#include <string>
#include <vector>

#include "args.h"
#include "peis/kernel.h"
#include "value_input.h"

namespace peis::cli {

struct Command {
  std::string name;
  std::string synopsis;              // "get OWNER.KEY"
  std::string summary;               // one line for `peis --help`
  std::string details;               // a few lines for `peis NAME --help`
  std::vector<std::string> options;  // accepted besides --help, --verbose, --peis-*
  bool tool = true;  // a short-lived tool PEIS (left out of `peis ls`); `node` is not
  int (*run)(Kernel& kernel, const Args& args) = nullptr;
  // A command that needs no PEIS of its own (`keys`): run instead of `run`.
  int (*runAlone)(const Options& options, const Args& args) = nullptr;
};

// Every built-in command, in the order the help lists them.
const std::vector<Command>& builtinCommands();
const Command* findBuiltin(const std::string& name);

// Checks the number of positional arguments; throws UsageError with the
// command's synopsis.
void expectArguments(const Args& args, std::size_t min, std::size_t max, const std::string& what);

// OWNER.KEY VALUE of set and append: the value (as written, -, @FILE; see
// value_input.h) and its owner, resolved and reachable within --timeout (5 s).
struct WriteRequest {
  PeisId owner = 0;
  std::string key;
  Value value;
};
WriteRequest readWriteRequest(Kernel& kernel, const Args& args);

// Runs the kernel until it quits or --timeout passes (without --timeout:
// until a quit or SIGINT/SIGTERM). False when --timeout ended it.
bool runUntilQuitOrTimeout(Kernel& kernel, const Args& args);

Command lsCommand();
Command nodeCommand();
Command infoCommand();
Command getCommand();
Command setCommand();
Command appendCommand();
Command eraseCommand();
Command metaCommand();
Command watchCommand();
Command hzCommand();
Command tuplesCommand();
Command keysCommand();

}  // namespace peis::cli
