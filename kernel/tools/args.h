// The `peis` tool's own options (--json, --wait S, ...): one table of every
// option with its kind, a parser that accepts them before, between or after
// the positional arguments ("--" ends the options), and typed reads. The
// --peis-* flags are taken out of argv before (peis::Options::fromArgs).
#pragma once

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace peis::cli {

// Bad usage: the message for the person, exit status 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class OptionKind {
  Flag,     // no value
  Seconds,  // 0..86400, fractions allowed
  Count,    // a whole number >= 1
  Number,   // a whole number >= 0
  Text,     // any text
};

struct OptionSpec {
  const char* name;       // "--wait"
  const char* shortName;  // "-v", or nullptr
  OptionKind kind;
  const char* valueName;  // "S", "N", "TYPE" (nullptr for a flag)
  const char* help;
};

// Every option of the tool, in the order the help lists them.
const std::vector<OptionSpec>& optionTable();
const OptionSpec* findOption(const std::string& nameOrShort);

struct Args {
  std::string command;
  std::vector<std::string> positional;
  std::map<std::string, std::string> given;  // long name -> value ("" for a flag); last wins

  bool has(const std::string& name) const { return given.count(name) > 0; }
  std::optional<double> seconds(const std::string& name) const;
  std::optional<long long> number(const std::string& name) const;
  std::optional<std::string> text(const std::string& name) const;
};

// Parses what Options::fromArgs left in argv (argv[0] is skipped). The first
// positional argument is the command. Throws UsageError.
Args parseArgs(int argc, char** argv);

// Index in argv of the command word, or -1: the first argument that is not
// an option or an option's value (the tool's or a --peis-* flag's).
int commandIndex(int argc, char** argv);

// Throws UsageError unless every option given is one `command` accepts
// (--help and --verbose are always accepted).
void checkOptions(const Args& args, const std::vector<std::string>& accepted);

}  // namespace peis::cli
