// Discovery beacons (docs/protocol.md §6): the UDP datagram a PEIS broadcasts
// to announce itself, with a checked decoder. Pure functions on bytes.
//
//   u32 magic "PEIB" | u16 version | str8 ecology | i32 id | u64 incarnation |
//   u16 tcp port | u8 flags (bit 0: please answer with a unicast beacon;
//   bit 1: the sender is a tool PEIS; bit 2: it is of a secured ecology;
//   bit 3: members follow) [ | u8 count | count x (i32 id | u64 incarnation |
//   u8[4] IPv4 address | u16 tcp port) ]
//
// Members ride only on answers (bit 0 clear): the PEIS a newcomer's answerer
// knows, so the newcomer knows the ecology at once (docs/protocol.md §6).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/types.h"

namespace peis::net {

inline constexpr std::uint32_t kBeaconMagic = 0x50454942;  // "PEIB"
// Members in one beacon: at most 22 + 255 + 1 + 64 * 18 = 1430 bytes, which
// an Ethernet frame carries unfragmented.
inline constexpr std::size_t kMaxBeaconMembers = 64;
inline constexpr std::size_t kMaxBeaconBytes = 22 + 255 + 1 + kMaxBeaconMembers * 18;

// A PEIS the sender heard, as it heard it.
struct BeaconMember {
  PeisId id = 0;
  std::uint64_t incarnation = 0;
  std::array<std::uint8_t, 4> address{};  // IPv4, in network order
  std::uint16_t port = 0;                 // TCP
  bool operator==(const BeaconMember&) const = default;
};

struct Beacon {
  std::string ecology;
  PeisId id = 0;
  std::uint64_t incarnation = 0;
  std::uint16_t port = 0;
  bool wantsAnswer = false;
  bool tool = false;
  bool secured = false;                 // a secured ecology's PEIS (docs/security.md)
  std::vector<BeaconMember> members{};  // answers only; at most kMaxBeaconMembers
  bool operator==(const Beacon&) const = default;
};

std::string encodeBeacon(const Beacon& beacon);
// Nothing for anything that is not exactly one valid beacon.
std::optional<Beacon> decodeBeacon(std::string_view bytes);

}  // namespace peis::net
