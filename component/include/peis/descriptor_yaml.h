// Descriptors embedded in other YAML files (a model file lists components
// inline): parse one from a yaml-cpp node so errors keep the outer file's
// lines. Needs yaml-cpp, which a caller of this header links itself.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string_view>

#include "peis/descriptor.h"

namespace peis {

// Throws Error(InvalidConfig) "<origin>:<line>: <problem>" like Descriptor::fromYaml.
Descriptor descriptorFromNode(const YAML::Node& node, std::string_view origin);

}  // namespace peis
