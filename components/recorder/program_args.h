// The command lines of peis-record, peis-inspect and peis-replay after the
// Kernel's --peis-* flags are gone: positional arguments, options with a
// value (`--name V`, `--name=V`, or a one-letter alias) and flags. A problem
// is a std::invalid_argument whose message the program prints with exit 2.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace peis::recorder {

struct ProgramArgs {
  std::vector<std::string> positional;
  std::map<std::string, std::string> values;  // by long name
  std::set<std::string> flags;
  bool help = false;

  bool has(const std::string& flag) const { return flags.count(flag) > 0; }
  std::optional<std::string> value(const std::string& name) const;
  // The value as a number in [low, high]; `fallback` when absent.
  double number(const std::string& name, double fallback, double low, double high) const;
};

// `valueOptions` and `flagOptions` are long names ("--output"); `aliases`
// maps short ones ("-o") to long ones. "--" ends the options.
ProgramArgs parseProgramArgs(int argc, char** argv, const std::set<std::string>& valueOptions,
                             const std::set<std::string>& flagOptions,
                             const std::map<std::string, std::string>& aliases = {});

}  // namespace peis::recorder
