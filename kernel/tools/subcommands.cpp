// Finding and running `peis-FOO` programs; see subcommands.h.
#include "subcommands.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <system_error>

#ifndef PEIS_LIBEXEC_FROM_BIN
#define PEIS_LIBEXEC_FROM_BIN "../libexec/peis"
#endif

namespace peis::cli {
namespace {

constexpr const char* kPrefix = "peis-";

std::vector<std::string> splitPath(const char* text) {
  std::vector<std::string> dirs;
  if (!text) return dirs;
  std::string dir;
  for (const char* p = text;; ++p) {
    if (*p == ':' || *p == '\0') {
      if (!dir.empty()) dirs.push_back(dir);
      dir.clear();
      if (*p == '\0') break;
    } else {
      dir += *p;
    }
  }
  return dirs;
}

bool isExecutableFile(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode) &&
         ::access(path.c_str(), X_OK) == 0;
}

}  // namespace

std::string selfPath() {
  std::error_code error;
  auto path = std::filesystem::read_symlink("/proc/self/exe", error);
  return error ? std::string() : path.string();
}

std::vector<std::string> subcommandDirs(const std::string& self) {
  std::vector<std::string> dirs = splitPath(std::getenv("PEIS_EXEC_PATH"));
  if (!self.empty()) {
    const auto binDir = std::filesystem::path(self).parent_path();
    dirs.push_back(binDir.string());
    dirs.push_back((binDir / PEIS_LIBEXEC_FROM_BIN).lexically_normal().string());
  }
  for (auto& dir : splitPath(std::getenv("PATH"))) dirs.push_back(std::move(dir));
  std::vector<std::string> unique;
  std::set<std::string> seen;
  for (auto& dir : dirs) {
    if (seen.insert(dir).second) unique.push_back(std::move(dir));
  }
  return unique;
}

bool isSubcommandName(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
  });
}

std::optional<std::string> findSubcommand(const std::string& name,
                                          const std::vector<std::string>& dirs) {
  if (!isSubcommandName(name)) return std::nullopt;
  for (const auto& dir : dirs) {
    const auto path = (std::filesystem::path(dir) / (kPrefix + name)).string();
    if (isExecutableFile(path)) return path;
  }
  return std::nullopt;
}

std::vector<std::string> listSubcommands(const std::vector<std::string>& dirs) {
  std::set<std::string> names;
  for (const auto& dir : dirs) {
    std::error_code error;
    std::filesystem::directory_iterator it(dir, error), end;
    for (; !error && it != end; it.increment(error)) {
      const auto file = it->path().filename().string();
      if (file.rfind(kPrefix, 0) != 0) continue;
      const auto name = file.substr(std::string(kPrefix).size());
      if (isSubcommandName(name) && isExecutableFile(it->path().string())) names.insert(name);
    }
  }
  return {names.begin(), names.end()};
}

void execSubcommand(const std::string& program, const std::vector<std::string>& args) {
  std::vector<std::string> storage{program};
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& arg : storage) argv.push_back(arg.data());
  argv.push_back(nullptr);
  ::execv(program.c_str(), argv.data());
}

}  // namespace peis::cli
