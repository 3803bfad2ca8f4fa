// Finding the programs a scenario runs, the way `peis FOO` finds `peis-FOO`
// (docs/cli.md), plus the build tree: a program name is looked up in
//   1. the directories of PEIS_EXEC_PATH (colon-separated);
//   2. the table `peis-scenario-programs.txt` beside peis-scenario, which a
//      build tree writes (every program of the build and the MCU firmware
//      directories; lines `program NAME PATH`, `firmware PORT DIR`);
//   3. the directory of peis-scenario itself;
//   4. the install's <prefix>/libexec/peis/ and <prefix>/bin/;
//   5. PATH.
// Only executable regular files count.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace peis::scenario {

class ProgramFinder {
 public:
  // `self`: the running program's path (/proc/self/exe); `execPath` and
  // `path`: the PEIS_EXEC_PATH and PATH variables.
  ProgramFinder(const std::string& self, const std::string& execPath, const std::string& path);
  // The finder of this process (its /proc/self/exe and environment).
  static ProgramFinder forThisProcess();

  std::optional<std::string> find(const std::string& name) const;
  // The firmware image of a tiny program for an MCU port (`avr`): `<dir>/<program>.elf`.
  std::optional<std::string> firmware(const std::string& port, const std::string& program) const;
  // Where it looked, for error messages.
  std::string searched() const;

 private:
  std::vector<std::string> before_, after_;  // directories before / after the table
  std::map<std::string, std::string> table_;
  std::map<std::string, std::string> firmwareDirs_;
};

bool isExecutableFile(const std::string& path);

}  // namespace peis::scenario
