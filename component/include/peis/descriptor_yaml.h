// Descriptors embedded in other YAML files (a model file lists components
// inline): parse one from a yaml-cpp node so errors keep the outer file's
// lines. A caller of this header includes <yaml-cpp/yaml.h> and links
// yaml-cpp itself (this header only names the type).
#pragma once

#include <string_view>

#include "peis/descriptor.h"

namespace YAML {
class Node;
}

namespace peis {

// Throws Error(InvalidConfig) "<origin>:<line>: <problem>" like Descriptor::fromYaml.
Descriptor descriptorFromNode(const YAML::Node& node, std::string_view origin);

}  // namespace peis
