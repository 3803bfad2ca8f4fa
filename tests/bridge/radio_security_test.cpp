// The tinybridge's secured radio (bridge/src/radio_security.h) without a
// radio: the radio keys file and its errors, the bridge's seal checked by
// the nodes' own MAC code (tiny_mac.c: SipHash-2-4 in C99 against
// libsodium's), a node's sealed frame taken once and refused when changed,
// replayed, unsecured or from a node the bridge does not vouch for, and the
// bridge's counter going on above what it used, across restarts.
#include "radio_security.h"

#include <catch2/catch.hpp>
#include <cstring>
#include <vector>

#include "peis/error.h"
#include "tiny_mac.h"
#include "tiny_tuple.h"

using peis::bridge::parseRadioKeys;
using peis::bridge::RadioSecurity;

namespace {

const char* kKeys =
    "# test keys\n"
    "bridge: 000102030405060708090a0b0c0d0e0f\n"
    "nodes:\n"
    "  3: 101112131415161718191a1b1c1d1e1f\n";

std::vector<std::uint8_t> beaconOf(std::uint16_t src) {
  std::vector<std::uint8_t> f(TINY_FRAME_MAX);
  f.resize(tiny_encode_beacon_frame(f.data(), src, 1, TINY_BEACON_TINY, 0, 1000));
  return f;
}

}  // namespace

TEST_CASE("radio security: keys files and their errors", "[unit]") {
  const auto keys = parseRadioKeys(kKeys, "keys.yaml");
  CHECK(keys.bridge[15] == 0x0f);
  CHECK(keys.nodes.at(3)[0] == 0x10);
  CHECK_THROWS_WITH(parseRadioKeys("nodes: {}\n", "k.yaml"), Catch::Contains("'bridge'"));
  CHECK_THROWS_WITH(parseRadioKeys("bridge: 00\n", "k.yaml"), Catch::Contains("k.yaml:1"));
  CHECK_THROWS_WITH(
      parseRadioKeys("bridge: 000102030405060708090a0b0c0d0e0f\nnodes:\n  0: 00\n", "k.yaml"),
      Catch::Contains("k.yaml:3") && Catch::Contains("not a node id"));
  CHECK_THROWS_WITH(parseRadioKeys("bridge: [\n", "k.yaml"), Catch::Contains("broken YAML"));
}

TEST_CASE("radio security: the bridge and the nodes compute the same MACs", "[unit]") {
  std::uint32_t stored = 0;
  RadioSecurity bridge(
      parseRadioKeys(kKeys, "k"), [&] { return stored; }, [&](std::uint32_t v) { stored = v; });
  CHECK(stored > 0);  // reserved ahead before the first frame
  auto frame = beaconOf(0xFFFE);
  std::size_t len = frame.size();
  frame.resize(TINY_FRAME_MAX);
  REQUIRE(bridge.seal(frame.data(), len));
  const auto keys = parseRadioKeys(kKeys, "k");
  CHECK(tiny_frame_mac_ok(frame.data(), len, keys.bridge.data()));
  CHECK_FALSE(tiny_frame_mac_ok(frame.data(), len, keys.nodes.at(3).data()));

  // A node's frame, sealed by the node's code, opened by the bridge once.
  auto node = beaconOf(3);
  std::size_t n = node.size();
  node.resize(TINY_FRAME_MAX);
  n = tiny_seal_frame(node.data(), n, keys.nodes.at(3).data(), 42);
  std::size_t opened = n;
  CHECK(bridge.open(node.data(), opened));
  CHECK(opened == n - TINY_SECURED_OVERHEAD);
  std::size_t again = n;
  std::string why;
  CHECK_FALSE(bridge.open(node.data(), again, &why));
  CHECK(why.find("replay") != std::string::npos);
  // Changed, unsecured, from a node the bridge does not vouch for.
  auto changed = node;
  changed[9] ^= 1;
  n = tiny_seal_frame(node.data(), beaconOf(3).size(), keys.nodes.at(3).data(), 43);
  changed.assign(node.begin(), node.begin() + n);
  changed[9] ^= 1;
  std::size_t c = changed.size();
  CHECK_FALSE(bridge.open(changed.data(), c));
  auto open = beaconOf(3);
  std::size_t o = open.size();
  CHECK_FALSE(bridge.open(open.data(), o, &why));
  CHECK(why.find("not a secured frame") != std::string::npos);
  auto stranger = beaconOf(9);
  std::size_t s = stranger.size();
  stranger.resize(TINY_FRAME_MAX);
  s = tiny_seal_frame(stranger.data(), s, keys.nodes.at(3).data(), 1);
  CHECK_FALSE(bridge.open(stranger.data(), s, &why));
  CHECK(why.find("no key") != std::string::npos);
  const auto stats = bridge.stats();
  CHECK(stats.replayed == 1);
  CHECK(stats.badMac == 1);
  CHECK(stats.unsecured == 1);
  CHECK(stats.unknownSender == 1);
}

TEST_CASE("radio security: the bridge's counter goes on above what it used after a restart",
          "[unit]") {
  std::uint32_t stored = 0;
  std::uint32_t lastUsed = 0;
  const auto keys = parseRadioKeys(kKeys, "k");
  {
    RadioSecurity bridge(
        keys, [&] { return stored; }, [&](std::uint32_t v) { stored = v; });
    for (int i = 0; i < 600; ++i) {
      auto f = beaconOf(0xFFFE);
      std::size_t len = f.size();
      f.resize(TINY_FRAME_MAX);
      REQUIRE(bridge.seal(f.data(), len));
      lastUsed = tiny_frame_counter(f.data(), len);
    }
  }
  RadioSecurity restarted(
      keys, [&] { return stored; }, [&](std::uint32_t v) { stored = v; });
  auto f = beaconOf(0xFFFE);
  std::size_t len = f.size();
  f.resize(TINY_FRAME_MAX);
  REQUIRE(restarted.seal(f.data(), len));
  CHECK(tiny_frame_counter(f.data(), len) > lastUsed);
}
