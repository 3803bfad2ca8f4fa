// peis: the command-line tool of the ecology. Each built-in command runs a
// short-lived PEIS of its own that joins the ecology, does one thing and
// leaves (command.h lists them, one file each). `peis FOO ...` for any other
// FOO runs the program `peis-FOO ...` (subcommands.h), so other parts (the
// meta-level's `peis config`) add commands without this tool linking them.
#include <cstring>
#include <iostream>

#include "command.h"
#include "peis/peis.h"
#include "subcommands.h"
#include "suggest.h"

namespace peis::cli {
namespace {

std::string optionsHelp(const std::vector<std::string>& accepted) {
  std::string text = "Options:\n";
  for (const auto& spec : optionTable()) {
    const std::string name = spec.name;
    const bool always = name == "--help" || name == "--verbose";
    if (!always && std::find(accepted.begin(), accepted.end(), name) == accepted.end()) continue;
    std::string left = "  " + name;
    if (spec.shortName) left += ", " + std::string(spec.shortName);
    if (spec.valueName) left += " " + std::string(spec.valueName);
    left.resize(std::max<std::size_t>(left.size() + 1, 20), ' ');
    text += left + spec.help + "\n";
  }
  return text;
}

std::string generalHelp(const std::vector<std::string>& external) {
  std::string text =
      "Usage: peis COMMAND [ARGS] [OPTIONS] [--peis-* options]\n"
      "\n"
      "Commands:\n";
  for (const auto& command : builtinCommands()) {
    std::string left = "  " + command.name;
    left.resize(10, ' ');
    text += left + command.summary + "\n";
  }
  if (!external.empty()) {
    text += "\nCommands of other programs (peis-NAME, see `peis NAME --help`):\n ";
    for (const auto& name : external) text += " " + name;
    text += "\n";
  }
  std::vector<std::string> all;
  for (const auto& spec : optionTable()) all.emplace_back(spec.name);
  text +=
      "\n"
      "OWNER is a PEIS id or name; in patterns also *. Keys may use * (one part)\n"
      "and a trailing ** (the rest). Options may come before or after the\n"
      "arguments; -- ends them. `peis COMMAND --help` says more. Exit status:\n"
      "0 done, 1 not found / not accepted / deadline, 2 bad usage.\n"
      "\n" +
      optionsHelp(all) + "\n" + Options::helpText();
  return text;
}

std::string commandHelp(const Command& command) {
  return "Usage: peis " + command.synopsis + " [OPTIONS] [--peis-* options]\n\n" + command.details +
         "\n\n" + optionsHelp(command.options) + "\n" + Options::helpText();
}

// External commands, without the names of built-in ones.
std::vector<std::string> externalCommands(const std::vector<std::string>& dirs) {
  std::vector<std::string> names;
  for (auto& name : listSubcommands(dirs)) {
    if (!findBuiltin(name)) names.push_back(std::move(name));
  }
  return names;
}

int usageError(const std::string& message, const std::string& command = "") {
  std::cerr << "peis: " << message << " (see peis " << (command.empty() ? "" : command + " ")
            << "--help)\n";
  return 2;
}

int exitStatusOf(const Error& e) {
  switch (e.code()) {
    case ErrorCode::InvalidArgument:
    case ErrorCode::InvalidKey:
    case ErrorCode::InvalidName:
      return 2;
    default:
      return 1;
  }
}

bool wantsHelp(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--") == 0) return false;
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) return true;
  }
  return false;
}

// Runs built-in `command` with what is left of argv.
int runBuiltin(const Command& command, int argc, char** argv) {
  Options options;
  Args args;
  try {
    options = Options::fromArgs(argc, argv);
    args = parseArgs(argc, argv);
    checkOptions(args, command.options);
  } catch (const Error& e) {
    return usageError(e.what(), command.name);
  } catch (const UsageError& e) {
    return usageError(e.what(), command.name);
  }
  if (args.has("--help")) {
    std::cout << commandHelp(command);
    return 0;
  }
  // A tool prints its result, not the kernel's log, unless asked.
  if (args.has("--verbose")) {
    log::setLevel(log::Level::Info);
  } else if (command.tool && !log::levelFromEnvironment()) {
    log::setLevel(log::Level::Warn);
  }
  options.tool = command.tool;
  try {
    if (command.runAlone) return command.runAlone(options, args);
    if (options.name.empty() && options.credentials.empty()) {
      options.name = command.tool ? "peis-" + command.name : command.name;
    }
    Kernel kernel(options);
    return command.run(kernel, args);
  } catch (const UsageError& e) {
    return usageError(e.what(), command.name);
  } catch (const Error& e) {
    std::cerr << "peis: " << e.what() << "\n";
    return exitStatusOf(e);
  }
}

int main(int argc, char** argv) {
  const auto dirs = subcommandDirs(selfPath());
  const int at = commandIndex(argc, argv);
  if (at < 0) {
    std::cout << generalHelp(externalCommands(dirs));
    return wantsHelp(argc, argv) ? 0 : 2;
  }
  std::string name = argv[at];
  // `peis help` and `peis help COMMAND` (= `peis COMMAND --help`).
  std::vector<std::string> rest(argv + at + 1, argv + argc);
  if (name == "help") {
    if (rest.empty()) {
      std::cout << generalHelp(externalCommands(dirs));
      return 0;
    }
    name = rest.front();
    rest = {"--help"};
  }
  if (const auto* command = findBuiltin(name)) {
    std::vector<std::string> storage{argv[0]};
    storage.insert(storage.end(), argv + 1, argv + at);
    storage.insert(storage.end(), rest.begin(), rest.end());
    storage.insert(storage.begin() + 1, name);  // the command word first
    std::vector<char*> args;
    for (auto& arg : storage) args.push_back(arg.data());
    args.push_back(nullptr);
    return runBuiltin(*command, static_cast<int>(storage.size()), args.data());
  }
  if (auto program = findSubcommand(name, dirs)) {
    // Everything but the command word goes to the program, in order.
    std::vector<std::string> args(argv + 1, argv + at);
    args.insert(args.end(), rest.begin(), rest.end());
    execSubcommand(*program, args);
    std::cerr << "peis: cannot run " << *program << ": " << std::strerror(errno) << "\n";
    return 1;
  }
  std::vector<std::string> known;
  for (const auto& command : builtinCommands()) known.push_back(command.name);
  for (auto& external : externalCommands(dirs)) known.push_back(std::move(external));
  return usageError("'" + name + "' is not a peis command (no built-in one, no program peis-" +
                    name + " in PEIS_EXEC_PATH, beside peis or in PATH)" +
                    didYouMean(closestNames(name, known)));
}

}  // namespace
}  // namespace peis::cli

int main(int argc, char** argv) { return peis::cli::main(argc, argv); }
