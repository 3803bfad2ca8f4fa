// Shared by the component programs' main(): the --peis-* flags and --help,
// number arguments, and the usual command-line errors (exit status 2).
#pragma once

#include <optional>
#include <string>

#include "peis/options.h"

namespace peis::components {

// Parses and removes the --peis-* flags into `options`, naming the PEIS
// `defaultName` unless --peis-name is given. With --help, prints `usage` and
// the PEIS flags and returns 0; on a bad flag prints the error and returns
// 2; otherwise nullopt: go on.
std::optional<int> parsePeisOptions(int& argc, char** argv, const std::string& program,
                                    const char* usage, const std::string& defaultName,
                                    Options& options);

// A decimal number in [low, high].
bool parseNumber(const char* text, double low, double high, double* out);

// Prints "<program>: <argument>: <why> (see --help)" and returns 2.
int badArgument(const std::string& program, const std::string& argument, const std::string& why);
// The complaint for an argument no option took (`value` is the next argument).
std::string unknownArgument(const std::string& argument, const char* value);

}  // namespace peis::components
