// Commands that other parts provide as programs, as git does: `peis FOO ARGS`
// runs a program `peis-FOO ARGS` found, in this order, in the directories of
// PEIS_EXEC_PATH (colon-separated), next to the `peis` binary, in the
// install's libexec directory (<prefix>/libexec/peis beside <prefix>/bin),
// and on PATH. So the kernel's tool never links the meta-level, yet
// `peis config plan ...` reaches meta/'s `peis-config`.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace peis::cli {

// The directories searched, in order, without repeats; `self` is the path
// of the running `peis` binary (empty: not known).
std::vector<std::string> subcommandDirs(const std::string& self);
// The running binary's path (/proc/self/exe), or empty.
std::string selfPath();

// True for a name a program may carry after "peis-": letters, digits, '-'
// and '_' (no '/', no '.': never a path).
bool isSubcommandName(const std::string& name);
// The first executable `peis-<name>` in `dirs`.
std::optional<std::string> findSubcommand(const std::string& name,
                                          const std::vector<std::string>& dirs);
// Every <name> of an executable `peis-<name>` in `dirs`, sorted, once each.
std::vector<std::string> listSubcommands(const std::vector<std::string>& dirs);

// Replaces this process with `program`; argv[0] becomes the program's path.
// Returns only when it could not start it (errno says why).
void execSubcommand(const std::string& program, const std::vector<std::string>& args);

}  // namespace peis::cli
