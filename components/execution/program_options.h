// The command line of the component programs, past the --peis-* flags the
// Kernel took: `--help` prints the usage and the PEIS flags; every other
// option is `--name value` (or a flag listed in `flags`), handed to `take`.
// `take` returns false for an unknown option or a bad value, or throws
// std::invalid_argument with its own message.
#pragma once

#include <functional>
#include <set>
#include <string>

namespace peis::exec {

using TakeOption = std::function<bool(const std::string& name, const std::string& value)>;

// With --help (or -h) anywhere: prints the usage and the PEIS flags and
// returns true. Called before the Kernel is made (the Kernel's own --help
// knows only the PEIS flags).
bool printedHelp(int argc, char** argv, const char* usage);

// Returns -1 to go on, or the exit code (0 after --help, 2 on a bad option).
int parseProgramOptions(int argc, char** argv, const std::string& program, const char* usage,
                        const TakeOption& take, const std::set<std::string>& flags = {});

}  // namespace peis::exec
