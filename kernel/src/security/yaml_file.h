// The security layer's YAML reading (credentials, trust roots, policies):
// every error is peis::Error(InvalidConfig) naming `origin:line` and the
// problem, and a file is written whole with mode 0600 (it may hold a secret).
// The parsing is yaml-cpp's, in the security module (backend.h).
#pragma once

#include <initializer_list>
#include <string>
#include <string_view>

#include "security/yaml_node.h"

namespace peis::security {

class YamlFile {
 public:
  explicit YamlFile(std::string origin) : origin_(std::move(origin)) {}
  // Reads and parses the file `origin` names.
  YamlNode load() const;
  // Parses `text` (origin names where it came from).
  YamlNode parse(std::string_view text) const;
  const std::string& origin() const { return origin_; }

  [[noreturn]] void fail(const YamlNode& at, const std::string& why) const;
  void onlyKeys(const YamlNode& map, std::initializer_list<const char*> known,
                const std::string& what) const;
  YamlNode required(const YamlNode& map, const char* key, const std::string& what) const;
  std::string text(const YamlNode& node, const std::string& what) const;
  // A string of hex digits holding exactly `bytes` bytes.
  std::string hexBytes(const YamlNode& node, std::size_t bytes, const std::string& what) const;

 private:
  std::string origin_;
};

// The whole of the file `path`; throws Error(InvalidConfig) naming it when
// it cannot be read.
std::string readTextFile(const std::string& path);

// Writes `text` to a new file `path` readable by its owner only; throws
// Error(InvalidArgument) when it exists (unless `replace`) or cannot be
// written.
void writeSecretFile(const std::string& path, const std::string& text, bool replace = false);

}  // namespace peis::security
