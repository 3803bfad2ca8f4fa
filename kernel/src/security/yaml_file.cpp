// YAML reading with file:line errors, and secret files; see yaml_file.h.
#include "security/yaml_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "peis/error.h"
#include "security/backend.h"
#include "security/crypto.h"

namespace peis::security {

std::string readTextFile(const std::string& path) {
  // stdio, not <fstream>: iostreams would link the locale machinery of the
  // statically linked libstdc++ into every program, whose code pages each
  // PEIS then maps (docs/performance.md, "Memory per PEIS").
  std::FILE* in = std::fopen(path.c_str(), "rb");
  if (in == nullptr) {
    throw Error(ErrorCode::InvalidConfig,
                path + ": cannot be read: " + std::string(std::strerror(errno)));
  }
  std::string text;
  char chunk[4096];
  std::size_t n = 0;
  while ((n = std::fread(chunk, 1, sizeof chunk, in)) > 0) text.append(chunk, n);
  const bool failed = std::ferror(in) != 0;
  const int error = errno;
  std::fclose(in);
  if (failed) {
    throw Error(ErrorCode::InvalidConfig,
                path + ": cannot be read: " + std::string(std::strerror(error)));
  }
  return text;
}

YamlNode YamlFile::load() const { return parse(readTextFile(origin_)); }

YamlNode YamlFile::parse(std::string_view text) const {
  YamlNode root;
  int line = -1;
  std::string error;
  if (!backend().parseYaml(text, root, line, error)) {
    throw Error(ErrorCode::InvalidConfig, origin_ + ":" + std::to_string(line + 1) + ": " + error);
  }
  return root;
}

void YamlFile::fail(const YamlNode& at, const std::string& why) const {
  const auto line = at.line >= 0 ? ":" + std::to_string(at.line + 1) : std::string();
  throw Error(ErrorCode::InvalidConfig, origin_ + line + ": " + why);
}

void YamlFile::onlyKeys(const YamlNode& map, std::initializer_list<const char*> known,
                        const std::string& what) const {
  if (!map.isMap()) fail(map, what + " must be a mapping");
  for (const auto& keyNode : map.keys) {
    const auto& key = keyNode.scalar;
    bool ok = false;
    for (const char* k : known) ok |= key == k;
    if (!ok) {
      std::string list;
      for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
      fail(keyNode, "unknown key '" + key + "' in " + what + " (known: " + list + ")");
    }
  }
}

YamlNode YamlFile::required(const YamlNode& map, const char* key, const std::string& what) const {
  const auto node = map[key];
  if (!node) fail(map, what + " has no '" + key + "'");
  return node;
}

std::string YamlFile::text(const YamlNode& node, const std::string& what) const {
  if (!node.isScalar()) fail(node, what + " must be a text");
  return node.scalar;
}

std::string YamlFile::hexBytes(const YamlNode& node, std::size_t bytes,
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
