// Functionality descriptors: what a component can do (typed inputs and
// outputs, preconditions, cost), read from the YAML file shipped with the
// component and published as tuples so the meta-level can plan with them.
// The YAML schema is in docs/components.md.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace peis {

struct Port {
  std::string name;  // a key part, e.g. "position"
  std::string type;  // e.g. "pose2d", "image/jpeg"
  bool operator==(const Port&) const = default;
};

struct Functionality {
  std::string name;
  std::string description;
  std::vector<Port> inputs;
  std::vector<Port> outputs;
  std::vector<std::string> preconditions;
  double cost = 1.0;
  bool operator==(const Functionality&) const = default;
};

struct Descriptor {
  std::string component;
  std::vector<Functionality> functionalities;

  // Throws Error(InvalidConfig) naming `origin`, the line and the problem.
  static Descriptor fromYaml(std::string_view text, std::string_view origin = "<yaml>");
  static Descriptor fromFile(const std::string& path);
  std::string toYaml() const;
};

// "name:type name:type" as published in functionality.<f>.inputs/outputs.
std::string formatPorts(const std::vector<Port>& ports);

}  // namespace peis
