// Test helper: a directory of its own under the temp directory (short
// enough for a UNIX socket path), removed with what it holds when the test
// ends.
#pragma once

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace peis::test {

struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& tag = "peis") {
    std::random_device random;
    path = std::filesystem::temp_directory_path() /
           (tag + "_" + std::to_string(random()) + std::to_string(random()));
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string file(const std::string& name) const { return (path / name).string(); }
  // Writes `text` to the file `name`; returns its path.
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name, std::ios::binary) << text;
    return file(name);
  }
};

}  // namespace peis::test
