// RadioSecurity: the tinybridge's side of a secured tiny radio
// (docs/security.md, tiny_tuple.h "secured frames"). The bridge holds the
// key of every node it vouches for (a secret YAML file, --radio-keys) and
// a key of its own; it takes a frame only from a node it holds the key of,
// with a MAC that checks and a counter above the last one taken from that
// node, and seals every frame it sends with its own key and counter (kept
// across restarts, a block at a time). The MAC is libsodium's SipHash-2-4
// (crypto_shorthash_siphash24), the one the nodes compute (tiny_mac.c).
//
//   # The tinybridge's radio keys. Keep secret.
//   bridge: 00112233445566778899aabbccddeeff
//   nodes:
//     3: 0f1e2d3c4b5a69788796a5b4c3d2e1f0
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>

namespace peis::bridge {

using RadioKey = std::array<std::uint8_t, 16>;

struct RadioKeys {
  RadioKey bridge{};
  std::map<std::uint16_t, RadioKey> nodes;
};
// Error(InvalidConfig) naming origin:line for every problem.
RadioKeys parseRadioKeys(const std::string& yamlText, const std::string& origin);
RadioKeys loadRadioKeys(const std::string& path);

struct RadioSecurityStats {
  std::uint64_t unsecured = 0, unknownSender = 0, badMac = 0, replayed = 0, tooLong = 0;
};

class RadioSecurity {
 public:
  // `loadCounter`/`storeCounter` keep the bridge's frame counter.
  RadioSecurity(RadioKeys keys, std::function<std::uint32_t()> loadCounter,
                std::function<void(std::uint32_t)> storeCounter);

  // Checks a received frame; true with `len` cut to the frame without its
  // trailer, or false (counted) with the reason in `why`.
  bool open(const std::uint8_t* frame, std::size_t& len, std::string* why = nullptr);
  // Seals a frame to send in place (buf has room for TINY_FRAME_MAX bytes);
  // false if it would not fit (counted).
  bool seal(std::uint8_t* frame, std::size_t& len);
  // Whether the bridge vouches for this node (holds its key).
  bool knows(std::uint16_t node) const { return keys_.nodes.count(node) != 0; }
  RadioSecurityStats stats() const { return stats_; }

 private:
  RadioKeys keys_;
  std::map<std::uint16_t, std::uint32_t> nextCounter_;  // per node: the lowest still taken
  std::function<void(std::uint32_t)> storeCounter_;
  std::uint32_t counter_ = 0, reserved_ = 0;
  RadioSecurityStats stats_;
};

}  // namespace peis::bridge
