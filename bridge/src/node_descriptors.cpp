// Tiny nodes' descriptors from the seed file (see node_descriptors.h).
#include "node_descriptors.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "peis/descriptor_yaml.h"
#include "peis/error.h"
#include "yaml_error.h"

namespace peis::bridge {
namespace {

[[noreturn]] void fail(const std::string& origin, const YAML::Node& node, const std::string& why) {
  failAt(origin, node, why);
}

}  // namespace

NodeDescriptors parseNodeDescriptors(const std::string& yamlText, const std::string& origin,
                                     const std::string& baseDir) {
  const YAML::Node root = loadYaml(yamlText, origin);
  NodeDescriptors descriptors;
  if (!root || !root.IsMap() || !root["descriptors"] || root["descriptors"].IsNull())
    return descriptors;
  const auto section = root["descriptors"];
  if (!section.IsMap()) fail(origin, section, "'descriptors' must be a mapping of node ids");
  try {
    for (const auto& item : section) {
      const auto idText = item.first.as<std::string>();
      long id = 0;
      std::size_t used = 0;
      try {
        id = std::stol(idText, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != idText.size() || id < 1 || id > 0xFFFE)
        fail(origin, item.first, "a tiny node id must be a whole number in 1..65534");
      if (descriptors.count(static_cast<std::uint16_t>(id)))
        fail(origin, item.first, "tiny node " + idText + " has two descriptors");
      if (item.second.IsScalar()) {
        auto path = std::filesystem::path(item.second.as<std::string>());
        if (path.is_relative()) path = std::filesystem::path(baseDir) / path;
        try {
          descriptors[static_cast<std::uint16_t>(id)] = Descriptor::fromFile(path.string());
        } catch (const Error& e) {
          fail(origin, item.second, std::string("in the descriptor: ") + e.what());
        }
      } else {
        descriptors[static_cast<std::uint16_t>(id)] = descriptorFromNode(item.second, origin);
      }
    }
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::InvalidConfig,
                origin + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  return descriptors;
}

NodeDescriptors loadNodeDescriptors(const std::string& seedPath) {
  std::ifstream in(seedPath);
  if (!in) throw Error(ErrorCode::InvalidConfig, seedPath + ": cannot read the key seed file");
  std::ostringstream text;
  text << in.rdbuf();
  const auto dir = std::filesystem::path(seedPath).parent_path();
  return parseNodeDescriptors(text.str(), seedPath, dir.empty() ? "." : dir.string());
}

}  // namespace peis::bridge
