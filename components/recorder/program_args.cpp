// Command lines of the recording programs (see program_args.h).
#include "recorder/program_args.h"

#include <cerrno>
#include <cstdlib>
#include <stdexcept>

namespace peis::recorder {

std::optional<std::string> ProgramArgs::value(const std::string& name) const {
  const auto it = values.find(name);
  if (it == values.end()) return std::nullopt;
  return it->second;
}

double ProgramArgs::number(const std::string& name, double fallback, double low,
                           double high) const {
  const auto text = value(name);
  if (!text) return fallback;
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(text->c_str(), &end);
  if (text->empty() || errno != 0 || *end != '\0' || !(x >= low && x <= high)) {
    char range[128];
    std::snprintf(range, sizeof range, "%g..%g", low, high);
    throw std::invalid_argument(name + ": '" + *text + "' is not a number in " + range);
  }
  return x;
}

ProgramArgs parseProgramArgs(int argc, char** argv, const std::set<std::string>& valueOptions,
                             const std::set<std::string>& flagOptions,
                             const std::map<std::string, std::string>& aliases) {
  ProgramArgs args;
  bool optionsEnded = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (optionsEnded || arg == "-" || arg.empty() || arg[0] != '-') {
      args.positional.push_back(arg);
      continue;
    }
    if (arg == "--") {
      optionsEnded = true;
      continue;
    }
    if (arg == "--help" || arg == "-h") {
      args.help = true;
      continue;
    }
    std::optional<std::string> inlineValue;
    if (const auto eq = arg.find('='); eq != std::string::npos && arg.rfind("--", 0) == 0) {
      inlineValue = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
    }
    if (const auto alias = aliases.find(arg); alias != aliases.end()) arg = alias->second;
    if (flagOptions.count(arg)) {
      if (inlineValue) throw std::invalid_argument(arg + " takes no value");
      args.flags.insert(arg);
    } else if (valueOptions.count(arg)) {
      if (!inlineValue && i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      args.values[arg] = inlineValue ? *inlineValue : argv[++i];
    } else {
      throw std::invalid_argument("unknown option " + arg);
    }
  }
  return args;
}

}  // namespace peis::recorder
