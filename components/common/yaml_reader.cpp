// YamlReader: YAML reading with file:line errors (see yaml_reader.h).
#include "yaml_reader.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "peis/error.h"

namespace peis::components {

YAML::Node YamlReader::parse(std::string_view text) const {
  try {
    return YAML::Load(std::string(text));
  } catch (const YAML::Exception& e) {
    const std::string line = e.mark.line >= 0 ? ":" + std::to_string(e.mark.line + 1) : "";
    throw Error(ErrorCode::InvalidConfig, origin_ + line + ": not valid YAML: " + e.msg);
  }
}

void YamlReader::fail(const YAML::Node& at, const std::string& why) const {
  std::string where = origin_;
  // An absent child of a const map is an invalid node without a mark.
  if (at.IsDefined() && at.Mark().line >= 0) where += ":" + std::to_string(at.Mark().line + 1);
  throw Error(ErrorCode::InvalidConfig, where + ": " + why);
}

void YamlReader::onlyKeys(const YAML::Node& map, std::initializer_list<const char*> known,
                          const std::string& what) const {
  if (!map.IsMap()) fail(map, what + " must be a mapping");
  for (const auto& item : map) {
    const auto key = item.first.Scalar();
    bool found = false;
    for (const char* k : known) found = found || key == k;
    if (found) continue;
    std::string list;
    for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
    fail(item.first, "unknown key '" + key + "' in " + what + " (known: " + list + ")");
  }
}

YAML::Node YamlReader::required(const YAML::Node& map, const char* key,
                                const std::string& what) const {
  const YAML::Node child = map[key];
  if (!child || child.IsNull()) fail(map, what + " needs '" + key + "'");
  return child;
}

double YamlReader::number(const YAML::Node& node, const std::string& what) const {
  if (!node.IsScalar()) fail(node, what + " must be a number");
  const std::string& text = node.Scalar();
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size())
    fail(node, what + " must be a number, not '" + text + "'");
  if (!std::isfinite(value)) fail(node, what + " must be finite");
  return value;
}

double YamlReader::number(const YAML::Node& map, const char* key, double fallback,
                          const std::string& what) const {
  const YAML::Node child = map[key];
  return child ? number(child, what) : fallback;
}

double YamlReader::numberIn(const YAML::Node& node, double low, double high,
                            const std::string& what) const {
  const double value = number(node, what);
  if (value < low || value > high) {
    std::ostringstream range;
    range << what << " must be in " << low << ".." << high << ", not " << value;
    fail(node, range.str());
  }
  return value;
}

double YamlReader::numberIn(const YAML::Node& map, const char* key, double fallback, double low,
                            double high, const std::string& what) const {
  const YAML::Node child = map[key];
  return child ? numberIn(child, low, high, what) : fallback;
}

std::vector<double> YamlReader::numbers(const YAML::Node& node, std::size_t count,
                                        const std::string& what) const {
  if (!node.IsSequence() || node.size() != count)
    fail(node, what + " must be a list of " + std::to_string(count) + " numbers");
  std::vector<double> values;
  for (const auto& item : node) values.push_back(number(item, what));
  return values;
}

std::string YamlReader::text(const YAML::Node& node, const std::string& what) const {
  if (!node.IsScalar()) fail(node, what + " must be a plain value");
  return node.Scalar();
}

std::string YamlReader::name(const YAML::Node& node, const std::string& what) const {
  const std::string value = text(node, what);
  bool ok = !value.empty() && value.size() <= 64;
  for (const unsigned char c : value)
    ok = ok && c > 0x20 && c < 0x7f && c != '.' && c != '*' && c != '=';
  if (!ok)
    fail(node,
         what + " '" + value + "' must be one key part (1..64 bytes, no '.', '*', '=', spaces)");
  return value;
}

bool YamlReader::flag(const YAML::Node& map, const char* key, bool fallback,
                      const std::string& what) const {
  const YAML::Node child = map[key];
  if (!child) return fallback;
  const std::string value = text(child, what);
  if (value == "true" || value == "yes") return true;
  if (value == "false" || value == "no") return false;
  fail(child, what + " must be true or false, not '" + value + "'");
}

std::vector<YAML::Node> YamlReader::list(const YAML::Node& node, const std::string& what) const {
  std::vector<YAML::Node> items;
  if (!node) return items;
  if (!node.IsSequence()) fail(node, what + " must be a list");
  for (const auto& item : node) items.push_back(item);
  return items;
}

std::string readTextFile(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::InvalidConfig, path + ": cannot open the " + what);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace peis::components
