// Shared command-line handling of the component programs (command_line.h).
#include "common/command_line.h"

#include <cerrno>
#include <cstdlib>
#include <iostream>

#include "peis/error.h"

namespace peis::components {

std::optional<int> parsePeisOptions(int& argc, char** argv, const std::string& program,
                                    const char* usage, const std::string& defaultName,
                                    Options& options) {
  try {
    options = Options::fromArgs(argc, argv);
  } catch (const Error& e) {
    std::cerr << program << ": " << e.what() << "\n";
    return 2;
  }
  if (options.help) {
    std::cout << usage << "\n" << Options::helpText();
    return 0;
  }
  if (!defaultName.empty() && (options.name.empty() || options.name == options.programName))
    options.name = defaultName;
  return std::nullopt;
}

bool parseNumber(const char* text, double low, double high, double* out) {
  if (text == nullptr || *text == '\0') return false;
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text, &end);
  if (errno != 0 || *end != '\0' || !(value >= low && value <= high)) return false;
  *out = value;
  return true;
}

int badArgument(const std::string& program, const std::string& argument, const std::string& why) {
  std::cerr << program << ": " << argument << ": " << why << " (see --help)\n";
  return 2;
}

std::string unknownArgument(const std::string& argument, const char* value) {
  return value == nullptr && argument.rfind("--", 0) == 0 ? "needs a value or is unknown"
                                                          : "unknown argument";
}

}  // namespace peis::components
