// Finding programs; see program_finder.h.
#include "program_finder.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace peis::scenario {
namespace {

std::vector<std::string> splitPath(const std::string& text) {
  std::vector<std::string> dirs;
  std::istringstream in(text);
  for (std::string dir; std::getline(in, dir, ':');) {
    if (!dir.empty()) dirs.push_back(dir);
  }
  return dirs;
}

}  // namespace

bool isExecutableFile(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(path.c_str(), X_OK) == 0;
}

ProgramFinder::ProgramFinder(const std::string& self, const std::string& execPath,
                             const std::string& path) {
  namespace fs = std::filesystem;
  before_ = splitPath(execPath);
  const fs::path selfDir = fs::path(self).parent_path();
  std::ifstream table(selfDir / "peis-scenario-programs.txt");
  for (std::string line; std::getline(table, line);) {
    std::istringstream words(line);
    std::string kind, name, where;
    if (!(words >> kind >> name >> where)) continue;
    if (kind == "program") table_[name] = where;
    if (kind == "firmware") firmwareDirs_[name] = where;
  }
  after_.push_back(selfDir.string());
  after_.push_back((selfDir.parent_path() / "libexec" / "peis").string());
  after_.push_back((selfDir.parent_path() / "bin").string());
  for (const auto& dir : splitPath(path)) after_.push_back(dir);
}

ProgramFinder ProgramFinder::forThisProcess() {
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  const char* execPath = std::getenv("PEIS_EXEC_PATH");
  const char* path = std::getenv("PATH");
  return ProgramFinder(error ? std::string() : self.string(), execPath ? execPath : "",
                       path ? path : "");
}

std::optional<std::string> ProgramFinder::find(const std::string& name) const {
  if (name.empty()) return std::nullopt;
  if (name.find('/') != std::string::npos) {
    if (isExecutableFile(name)) return name;
    return std::nullopt;
  }
  for (const auto& dir : before_) {
    if (isExecutableFile(dir + "/" + name)) return dir + "/" + name;
  }
  if (const auto it = table_.find(name); it != table_.end() && isExecutableFile(it->second))
    return it->second;
  for (const auto& dir : after_) {
    if (isExecutableFile(dir + "/" + name)) return dir + "/" + name;
  }
  return std::nullopt;
}

std::optional<std::string> ProgramFinder::firmware(const std::string& port,
                                                   const std::string& program) const {
  const auto it = firmwareDirs_.find(port);
  if (it == firmwareDirs_.end()) return std::nullopt;
  const std::string path = it->second + "/" + program + ".elf";
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt;
  return path;
}

std::string ProgramFinder::searched() const {
  std::string text;
  for (const auto& dir : before_) text += (text.empty() ? "" : ", ") + dir;
  if (!table_.empty()) text += std::string(text.empty() ? "" : ", ") + "the build tree";
  for (const auto& dir : after_) text += (text.empty() ? "" : ", ") + dir;
  return text;
}

}  // namespace peis::scenario
