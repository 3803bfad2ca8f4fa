// YAML reading with file:line errors, and secret files; see yaml_file.h.
#include "security/yaml_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "peis/error.h"
#include "security/crypto.h"

namespace peis::security {

YAML::Node YamlFile::load() const {
  std::ifstream in(origin_);
  if (!in) {
    throw Error(ErrorCode::InvalidConfig,
                origin_ + ": cannot be read: " + std::string(std::strerror(errno)));
  }
  std::stringstream text;
  text << in.rdbuf();
  return parse(text.str());
}

YAML::Node YamlFile::parse(std::string_view text) const {
  try {
    return YAML::Load(std::string(text));
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::InvalidConfig,
                origin_ + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

void YamlFile::fail(const YAML::Node& at, const std::string& why) const {
  const auto mark = at.Mark();
  const auto line = mark.line >= 0 ? ":" + std::to_string(mark.line + 1) : std::string();
  throw Error(ErrorCode::InvalidConfig, origin_ + line + ": " + why);
}

void YamlFile::onlyKeys(const YAML::Node& map, std::initializer_list<const char*> known,
                        const std::string& what) const {
  if (!map.IsMap()) fail(map, what + " must be a mapping");
  for (const auto& entry : map) {
    const auto key = entry.first.as<std::string>();
    bool ok = false;
    for (const char* k : known) ok |= key == k;
    if (!ok) {
      std::string list;
      for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      fail(entry.first, "unknown key '" + key + "' in " + what + " (known: " + list + ")");
    }
  }
}

YAML::Node YamlFile::required(const YAML::Node& map, const char* key,
                              const std::string& what) const {
  const auto node = map[key];
  if (!node) fail(map, what + " has no '" + key + "'");
  return node;
}

std::string YamlFile::text(const YAML::Node& node, const std::string& what) const {
  if (!node.IsScalar()) fail(node, what + " must be a text");
  return node.as<std::string>();
}

std::string YamlFile::hexBytes(const YAML::Node& node, std::size_t bytes,
                               const std::string& what) const {
  const auto value = fromHex(text(node, what));
  if (!value || value->size() != bytes) {
    fail(node, what + " must be " + std::to_string(bytes) + " bytes in hex");
  }
  return *value;
}

void writeSecretFile(const std::string& path, const std::string& text, bool replace) {
  const int flags = O_WRONLY | O_CREAT | (replace ? O_TRUNC : O_EXCL);
  const int fd = ::open(path.c_str(), flags, 0600);
  if (fd < 0) {
    throw Error(ErrorCode::InvalidArgument,
                path + ": cannot be written: " + std::string(std::strerror(errno)) +
                    (errno == EEXIST ? " (it exists; nothing was changed)" : ""));
  }
  std::size_t done = 0;
  while (done < text.size()) {
    const auto n = ::write(fd, text.data() + done, text.size() - done);
    if (n <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      throw Error(ErrorCode::InvalidArgument, path + ": cannot be written: " + why);
    }
    done += static_cast<std::size_t>(n);
  }
  ::fchmod(fd, 0600);
  ::close(fd);
}

}  // namespace peis::security
