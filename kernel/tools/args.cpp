// Parsing of the `peis` tool's own options; see args.h.
#include "args.h"

#include <algorithm>
#include <cctype>

#include "peis/options.h"
#include "suggest.h"

namespace peis::cli {
namespace {

bool isOptionLike(const std::string& arg) {
  // "-" is a value (stdin); "-5" and "-.5" are numbers, not options.
  return arg.size() > 1 && arg[0] == '-' && !std::isdigit(static_cast<unsigned char>(arg[1])) &&
         arg[1] != '.';
}

std::string checkedValue(const OptionSpec& spec, const std::string& value) {
  const std::string name = spec.name;
  auto fail = [&](const std::string& what) -> std::string {
    throw UsageError(name + " needs " + what + ", not '" + value + "'");
  };
  switch (spec.kind) {
    case OptionKind::Flag:
    case OptionKind::Text:
      return value;
    case OptionKind::Seconds: {
      try {
        std::size_t used = 0;
        const double seconds = std::stod(value, &used);
        if (used != value.size() || !(seconds >= 0) || seconds > 86400) fail("seconds in 0..86400");
      } catch (const std::logic_error&) {
        fail("a number of seconds");
      }
      return value;
    }
    case OptionKind::Count:
    case OptionKind::Number: {
      const bool digits = !value.empty() && value.size() <= 18 &&
                          std::all_of(value.begin(), value.end(), [](char c) {
                            return std::isdigit(static_cast<unsigned char>(c));
                          });
      if (!digits) fail("a whole number");
      if (spec.kind == OptionKind::Count && std::stoll(value) < 1) fail("a number of at least 1");
      return value;
    }
  }
  return value;
}

}  // namespace

const std::vector<OptionSpec>& optionTable() {
  static const std::vector<OptionSpec> table{
      {"--json", nullptr, OptionKind::Flag, nullptr, "machine-readable output"},
      {"--wait", nullptr, OptionKind::Seconds, "S", "how long to wait for the answer"},
      {"--timeout", nullptr, OptionKind::Seconds, "S",
       "deadline: owner reachable (writes), stop after S seconds (watch, hz)"},
      {"--count", nullptr, OptionKind::Count, "N", "stop after N lines (watch) or reports (hz)"},
      {"--all", "-a", OptionKind::Flag, nullptr, "ls: also the short-lived tool PEIS"},
      {"--raw", nullptr, OptionKind::Flag, nullptr,
       "get: the data exactly, binary too, with no newline"},
      {"--stamps", nullptr, OptionKind::Flag, nullptr,
       "watch: each line starts with the time of the change"},
      {"--ttl", nullptr, OptionKind::Seconds, "S", "set: the value expires S seconds after"},
      {"--mimetype", nullptr, OptionKind::Text, "TYPE", "set: the value's mimetype"},
      {"--literal", nullptr, OptionKind::Flag, nullptr,
       "set, append: VALUE as written ('-' and '@FILE' not read)"},
      {"--if-seqno", nullptr, OptionKind::Number, "N",
       "append: only if the tuple's seqno is still N (0: absent)"},
      {"--interval", nullptr, OptionKind::Seconds, "S", "hz: seconds between reports (1)"},
      {"--window", nullptr, OptionKind::Count, "N", "hz: intervals kept per key (100)"},
      {"--clock", nullptr, OptionKind::Text, "C",
       "hz: arrival (here), write (owner's ts_write) or user (ts_user)"},
      {"--dir", nullptr, OptionKind::Text, "DIR", "keys: the trust root's directory (peis-keys)"},
      {"--group", nullptr, OptionKind::Text, "G[,G]", "keys add: the groups of the principal"},
      {"--names", nullptr, OptionKind::Text, "P[,P]",
       "keys add: PEIS names its holders may use (NAME; 'x-*' a prefix, '*' any)"},
      {"--id", nullptr, OptionKind::Count, "N", "keys add: the id its holder always has"},
      {"--days", nullptr, OptionKind::Number, "N",
       "keys add: days the credentials are valid (365; 0 never expire)"},
      {"--out", nullptr, OptionKind::Text, "FILE", "keys add: where to write (DIR/NAME.cred)"},
      {"--force", nullptr, OptionKind::Flag, nullptr, "keys add: replace an existing file"},
      {"--verbose", "-v", OptionKind::Flag, nullptr, "the kernel's info lines on stderr"},
      {"--help", "-h", OptionKind::Flag, nullptr, "show this help"},
  };
  return table;
}

const OptionSpec* findOption(const std::string& nameOrShort) {
  for (const auto& spec : optionTable()) {
    if (nameOrShort == spec.name || (spec.shortName && nameOrShort == spec.shortName)) {
      return &spec;
    }
  }
  return nullptr;
}

std::optional<double> Args::seconds(const std::string& name) const {
  auto it = given.find(name);
  if (it == given.end()) return std::nullopt;
  return std::stod(it->second);
}

std::optional<long long> Args::number(const std::string& name) const {
  auto it = given.find(name);
  if (it == given.end()) return std::nullopt;
  return std::stoll(it->second);
}

std::optional<std::string> Args::text(const std::string& name) const {
  auto it = given.find(name);
  if (it == given.end()) return std::nullopt;
  return it->second;
}

Args parseArgs(int argc, char** argv) {
  Args args;
  auto addPositional = [&](const std::string& arg) {
    (args.command.empty() ? args.command : args.positional.emplace_back()) = arg;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") {  // the rest are arguments, even if they start with '-'
      for (++i; i < argc; ++i) addPositional(argv[i]);
      break;
    }
    if (!isOptionLike(arg)) {
      addPositional(arg);
      continue;
    }
    std::string name = arg, value;
    bool hasValue = false;
    if (const auto eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      name = arg.substr(0, eq);
      value = arg.substr(eq + 1);
      hasValue = true;
    }
    const auto* spec = findOption(name);
    if (!spec) {
      std::vector<std::string> names;
      for (const auto& each : optionTable()) names.emplace_back(each.name);
      throw UsageError("unknown option " + name + didYouMean(closestNames(name, names)));
    }
    if (spec->kind == OptionKind::Flag) {
      if (hasValue) throw UsageError(std::string(spec->name) + " takes no value");
    } else if (!hasValue) {
      if (i + 1 >= argc) throw UsageError(std::string(spec->name) + " needs a value");
      value = argv[++i];
    }
    args.given[spec->name] = checkedValue(*spec, value);
  }
  return args;
}

int commandIndex(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") return i + 1 < argc ? i + 1 : -1;
    if (!isOptionLike(arg)) return i;
    if (arg.find('=') != std::string::npos) continue;
    const auto* spec = findOption(arg);
    const bool takesValue = spec ? spec->kind != OptionKind::Flag : Options::isValueFlag(arg);
    if (takesValue) ++i;
  }
  return -1;
}

void checkOptions(const Args& args, const std::vector<std::string>& accepted) {
  for (const auto& [name, value] : args.given) {
    if (name == "--help" || name == "--verbose") continue;
    if (std::find(accepted.begin(), accepted.end(), name) == accepted.end()) {
      throw UsageError(args.command + " does not take " + name);
    }
  }
}

}  // namespace peis::cli
