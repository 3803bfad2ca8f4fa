// The component programs' own options (see program_options.h).
#include "execution/program_options.h"

#include <peis/options.h>

#include <iostream>
#include <stdexcept>

namespace peis::exec {

bool printedHelp(int argc, char** argv, const char* usage) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << usage << "\n" << Options::helpText();
      return true;
    }
  }
  return false;
}

int parseProgramOptions(int argc, char** argv, const std::string& program, const char* usage,
                        const TakeOption& take, const std::set<std::string>& flags) {
  for (int i = 1; i < argc; ++i) {
    const std::string name = argv[i];
    if (name == "--help" || name == "-h") {
      std::cout << usage << "\n" << Options::helpText();
      return 0;
    }
    const bool flag = flags.count(name) > 0;
    if (!flag && i + 1 >= argc) {
      std::cerr << program << ": unknown option or missing value: " << name << " (see --help)\n";
      return 2;
    }
    const std::string value = flag ? "" : argv[++i];
    try {
      if (!take(name, value)) {
        std::cerr << program << ": unknown option or bad value: " << name << " '" << value
                  << "' (see --help)\n";
        return 2;
      }
    } catch (const std::invalid_argument& e) {
      std::cerr << program << ": " << e.what() << "\n";
      return 2;
    }
  }
  return -1;
}

}  // namespace peis::exec
