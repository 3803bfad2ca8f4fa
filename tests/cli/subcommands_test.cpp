// Finding `peis-FOO` programs (kernel/tools/subcommands.h): the search
// order, what counts as a program, names that could be paths.
#include "subcommands.h"

#include <sys/stat.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>

#include "support/scoped_env.h"
#include "support/temp_dir.h"

using peis::cli::findSubcommand;
using peis::cli::listSubcommands;
using peis::cli::subcommandDirs;
using peis::test::ScopedEnv;
using Strings = std::vector<std::string>;

namespace {

std::string program(const peis::test::TempDir& dir, const std::string& name,
                    bool executable = true) {
  const auto path = dir.write(name, "#!/bin/sh\necho " + name + "\n");
  ::chmod(path.c_str(), executable ? 0755 : 0644);
  return path;
}

}  // namespace

TEST_CASE("the first executable peis-NAME in the directories wins", "[unit][cli]") {
  peis::test::TempDir first("peis-sub1"), second("peis-sub2");
  program(second, "peis-config");
  const auto preferred = program(first, "peis-config");
  program(first, "peis-notes", false);  // not executable: not a command
  const auto later = program(second, "peis-notes");
  ::mkdir(first.file("peis-dir").c_str(), 0755);  // a directory is no program

  const Strings dirs{first.path.string(), second.path.string()};
  CHECK(findSubcommand("config", dirs) == preferred);
  CHECK(findSubcommand("notes", dirs) == later);
  CHECK_FALSE(findSubcommand("dir", dirs).has_value());
  CHECK_FALSE(findSubcommand("absent", dirs).has_value());
  CHECK(listSubcommands(dirs) == Strings{"config", "notes"});
  CHECK(listSubcommands({"/nonexistent/dir"}).empty());
}

TEST_CASE("a command name never reaches outside the directories", "[unit][cli]") {
  peis::test::TempDir dir("peis-sub3");
  std::filesystem::create_directories(dir.path / "peis-x");
  program(dir, "peis-x/y");
  const Strings dirs{dir.path.string()};
  CHECK_FALSE(peis::cli::isSubcommandName("x/y"));
  CHECK_FALSE(peis::cli::isSubcommandName("../peis-x"));
  CHECK_FALSE(peis::cli::isSubcommandName(""));
  CHECK(peis::cli::isSubcommandName("config_2-b"));
  CHECK_FALSE(findSubcommand("x/y", dirs).has_value());
}

TEST_CASE("the search order: PEIS_EXEC_PATH, beside peis, libexec, PATH", "[unit][cli]") {
  ScopedEnv execPath("PEIS_EXEC_PATH", "/opt/a:/opt/b");
  ScopedEnv path("PATH", "/usr/bin:/opt/a:/bin");
  const auto dirs = subcommandDirs("/usr/local/bin/peis");
  CHECK(dirs == Strings{"/opt/a", "/opt/b", "/usr/local/bin", "/usr/local/libexec/peis", "/usr/bin",
                        "/bin"});
  const auto unknownSelf = subcommandDirs("");
  CHECK(unknownSelf == Strings{"/opt/a", "/opt/b", "/usr/bin", "/bin"});
}
