// The functionality descriptors of tiny nodes, from the bridge's seed file
// (section `descriptors`: tiny node id -> a descriptor inline, or the path of
// a descriptor file relative to the seed). A node's proxy publishes its
// descriptor as any component does (peis::Component), so the meta-level can
// plan with the node: its outputs are the tuples the node writes (`key:
// Weight`), and links to them are radio links (docs/tinybridge.md).
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "peis/descriptor.h"

namespace peis::bridge {

using NodeDescriptors = std::map<std::uint16_t, Descriptor>;

// Throws Error(InvalidConfig) "<origin>:<line>: <problem>" (a bad node id, a
// broken descriptor, a file that cannot be read).
NodeDescriptors parseNodeDescriptors(const std::string& yamlText, const std::string& origin,
                                     const std::string& baseDir = ".");
NodeDescriptors loadNodeDescriptors(const std::string& seedPath);

}  // namespace peis::bridge
