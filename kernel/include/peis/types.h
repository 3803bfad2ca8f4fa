// Basic value types of the PEIS tuple model: identifiers, timestamps,
// encodings and the hard limits that every part of the kernel enforces.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>

namespace peis {

// A PEIS id: a positive 31-bit integer, unique within one ecology.
using PeisId = std::int32_t;
inline constexpr PeisId kMinPeisId = 1;
inline constexpr PeisId kMaxPeisId = 0x7fffffff;
inline constexpr bool isValidPeisId(std::int64_t id) {
  return id >= kMinPeisId && id <= kMaxPeisId;
}

// Wall-clock time with microsecond resolution. The epoch value means
// "not set" (for ts_expire: never expires).
using Timestamp = std::chrono::sys_time<std::chrono::microseconds>;
inline constexpr Timestamp kNoTime{};
inline Timestamp systemNow() {
  return std::chrono::time_point_cast<std::chrono::microseconds>(std::chrono::system_clock::now());
}

// How the data bytes of a tuple are meant to be read.
enum class Encoding : std::uint8_t { Ascii = 0, Binary = 1 };

// Limits from tiny-peis-kernel.txt (Fig. 4): keys up to 256 bytes, data up
// to 2^31-1 bytes. A PEIS may impose a lower data limit (Options).
inline constexpr std::size_t kMaxKeyBytes = 256;
inline constexpr std::size_t kMaxKeyParts = 32;
inline constexpr std::size_t kMaxDataBytes = 0x7fffffff;
inline constexpr std::size_t kDefaultMaxDataBytes = 64u * 1024u * 1024u;
inline constexpr std::size_t kMaxNameBytes = 64;
inline constexpr std::size_t kMaxMimetypeBytes = 128;

}  // namespace peis
