// Discovery beacons (docs/protocol.md §6): the UDP datagram a PEIS broadcasts
// to announce itself, with a checked decoder. Pure functions on bytes.
//
//   u32 magic "PEIB" | u16 version | str8 ecology | i32 id | u64 incarnation |
//   u16 tcp port | u8 flags (bit 0: please answer with a unicast beacon;
//   bit 1: the sender is a tool PEIS; bit 2: it is of a secured ecology)
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "peis/types.h"

namespace peis::net {

inline constexpr std::uint32_t kBeaconMagic = 0x50454942;  // "PEIB"

struct Beacon {
  std::string ecology;
  PeisId id = 0;
  std::uint64_t incarnation = 0;
  std::uint16_t port = 0;
  bool wantsAnswer = false;
  bool tool = false;
  bool secured = false;  // a secured ecology's PEIS (docs/security.md)
  bool operator==(const Beacon&) const = default;
};

std::string encodeBeacon(const Beacon& beacon);
// Nothing for anything that is not exactly one valid beacon.
std::optional<Beacon> decodeBeacon(std::string_view bytes);

}  // namespace peis::net
