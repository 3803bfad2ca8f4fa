// The tinybridge's secured radio; see radio_security.h.
#include "radio_security.h"

#include <sodium.h>
#include <yaml-cpp/yaml.h>

#include <charconv>
#include <fstream>
#include <sstream>

#include "peis/error.h"
#include "tiny_tuple.h"

namespace peis::bridge {

namespace {

constexpr std::uint32_t kCounterBlock = 256;  // frames per write of the counter

[[noreturn]] void fail(const std::string& origin, const YAML::Node& at, const std::string& why) {
  const auto line = at.Mark().line >= 0 ? ":" + std::to_string(at.Mark().line + 1) : "";
  throw Error(ErrorCode::InvalidConfig, origin + line + ": " + why);
}

RadioKey keyOf(const std::string& origin, const YAML::Node& node, const std::string& what) {
  if (!node.IsScalar()) fail(origin, node, what + " must be 32 hex digits");
  const auto text = node.as<std::string>();
  RadioKey key{};
  if (text.size() != 32) fail(origin, node, what + " must be 32 hex digits");
  for (std::size_t i = 0; i < 16; ++i) {
    unsigned v = 0;
    const auto [end, ec] = std::from_chars(text.data() + 2 * i, text.data() + 2 * i + 2, v, 16);
    if (ec != std::errc() || end != text.data() + 2 * i + 2)
      fail(origin, node, what + " must be 32 hex digits");
    key[i] = static_cast<std::uint8_t>(v);
  }
  return key;
}

std::uint32_t counterOf(const std::uint8_t* frame, std::size_t len) {
  const auto* p = frame + len - TINY_SECURED_OVERHEAD;
  return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 |
         std::uint32_t{p[3]} << 24;
}

}  // namespace

RadioKeys parseRadioKeys(const std::string& yamlText, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(yamlText);
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::InvalidConfig,
                origin + ":" + std::to_string(e.mark.line + 1) + ": broken YAML: " + e.msg);
  }
  if (!root.IsMap() || !root["bridge"]) fail(origin, root, "radio keys need 'bridge' and 'nodes'");
  for (const auto& item : root) {
    const auto section = item.first.as<std::string>();
    if (section != "bridge" && section != "nodes")
      fail(origin, item.first, "unknown key '" + section + "' (known: bridge, nodes)");
  }
  RadioKeys keys;
  keys.bridge = keyOf(origin, root["bridge"], "the bridge's key");
  if (const auto nodes = root["nodes"]) {
    if (!nodes.IsMap()) fail(origin, nodes, "'nodes' must be a mapping of node id to key");
    for (const auto& item : nodes) {
      unsigned long id = 0;
      const auto text = item.first.as<std::string>();
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
      if (ec != std::errc() || end != text.data() + text.size() || id == 0 || id > 0xFFFE)
        fail(origin, item.first, "'" + text + "' is not a node id (1..65534)");
      keys.nodes[static_cast<std::uint16_t>(id)] =
          keyOf(origin, item.second, "the key of node " + text);
    }
  }
  return keys;
}

RadioKeys loadRadioKeys(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorCode::InvalidConfig, path + ": cannot read the radio keys");
  std::ostringstream text;
  text << in.rdbuf();
  return parseRadioKeys(text.str(), path);
}

RadioSecurity::RadioSecurity(RadioKeys keys, std::function<std::uint32_t()> loadCounter,
                             std::function<void(std::uint32_t)> storeCounter)
    : keys_(std::move(keys)), storeCounter_(std::move(storeCounter)) {
  if (sodium_init() < 0) throw Error(ErrorCode::InvalidConfig, "libsodium cannot start");
  counter_ = loadCounter();
  reserved_ = counter_ + kCounterBlock;
  storeCounter_(reserved_);  // a restart goes on above every counter used
}

bool RadioSecurity::open(const std::uint8_t* frame, std::size_t& len, std::string* why) {
  auto refuse = [&](std::uint64_t& counter, const char* reason) {
    ++counter;
    if (why) *why = reason;
    return false;
  };
  if (len < TINY_FRAME_HEADER_SIZE + TINY_SECURED_OVERHEAD || len > TINY_FRAME_MAX ||
      frame[TINY_FOFF_VERSION] != TINY_SECURED_VERSION) {
    return refuse(stats_.unsecured, "not a secured frame");
  }
  const std::uint16_t src =
      static_cast<std::uint16_t>(frame[TINY_FOFF_SRC] | frame[TINY_FOFF_SRC + 1] << 8);
  const auto key = keys_.nodes.find(src);
  if (key == keys_.nodes.end()) {
    return refuse(stats_.unknownSender, "the bridge holds no key for its sender");
  }
  std::uint8_t mac[TINY_MAC_SIZE];
  crypto_shorthash_siphash24(mac, frame, len - TINY_MAC_SIZE, key->second.data());
  if (sodium_memcmp(mac, frame + len - TINY_MAC_SIZE, TINY_MAC_SIZE) != 0) {
    return refuse(stats_.badMac, "its MAC does not check");
  }
  const auto counter = counterOf(frame, len);
  auto& next = nextCounter_[src];
  if (counter < next) {
    return refuse(stats_.replayed, "its counter is old (a replay)");
  }
  next = counter + 1;
  len -= TINY_SECURED_OVERHEAD;
  return true;
}

bool RadioSecurity::seal(std::uint8_t* frame, std::size_t& len) {
  if (len < TINY_FRAME_HEADER_SIZE || len + TINY_SECURED_OVERHEAD > TINY_FRAME_MAX) {
    ++stats_.tooLong;
    return false;
  }
  if (counter_ == reserved_) {
    reserved_ += kCounterBlock;
    storeCounter_(reserved_);
  }
  const auto counter = counter_++;
  frame[TINY_FOFF_VERSION] = TINY_SECURED_VERSION;
  for (int i = 0; i < 4; ++i) frame[len + i] = static_cast<std::uint8_t>(counter >> (8 * i));
  crypto_shorthash_siphash24(frame + len + TINY_COUNTER_SIZE, frame, len + TINY_COUNTER_SIZE,
                             keys_.bridge.data());
  len += TINY_SECURED_OVERHEAD;
  return true;
}

}  // namespace peis::bridge
