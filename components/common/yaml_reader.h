// YamlReader: reads the components' YAML files (world files, camera files,
// tracking targets) with every error naming `origin:line` and the problem,
// the way descriptor errors do. Throws peis::Error(InvalidConfig).
#pragma once

#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace peis::components {

class YamlReader {
 public:
  explicit YamlReader(std::string origin) : origin_(std::move(origin)) {}

  // Parses `text`; a syntax error names the line.
  YAML::Node parse(std::string_view text) const;
  const std::string& origin() const { return origin_; }

  // "origin:line: why" (the line of `at` when it has one).
  [[noreturn]] void fail(const YAML::Node& at, const std::string& why) const;
  // Every key of `map` must be one of `known`; `what` names the mapping.
  void onlyKeys(const YAML::Node& map, std::initializer_list<const char*> known,
                const std::string& what) const;
  // The child `key` of `map`, which must be there.
  YAML::Node required(const YAML::Node& map, const char* key, const std::string& what) const;

  // A finite number.
  double number(const YAML::Node& node, const std::string& what) const;
  double number(const YAML::Node& map, const char* key, double fallback,
                const std::string& what) const;
  // A number in [low, high].
  double numberIn(const YAML::Node& node, double low, double high, const std::string& what) const;
  double numberIn(const YAML::Node& map, const char* key, double fallback, double low, double high,
                  const std::string& what) const;
  // A list of exactly `count` numbers.
  std::vector<double> numbers(const YAML::Node& node, std::size_t count,
                              const std::string& what) const;
  // A plain value.
  std::string text(const YAML::Node& node, const std::string& what) const;
  // A plain value usable as one key part (no '.', '*', '=', spaces, 1..64 bytes).
  std::string name(const YAML::Node& node, const std::string& what) const;
  bool flag(const YAML::Node& map, const char* key, bool fallback, const std::string& what) const;
  // A list (sequence); an absent node gives an empty list.
  std::vector<YAML::Node> list(const YAML::Node& node, const std::string& what) const;

 private:
  std::string origin_;
};

// Reads a whole file; Error(InvalidConfig) "path: cannot open ..." if it cannot.
std::string readTextFile(const std::string& path, const std::string& what);

}  // namespace peis::components
