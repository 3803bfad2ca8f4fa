// Beacon encoding and checked decoding; layout in beacon.h.
#include "net/beacon.h"

#include "net/wire_format.h"

namespace peis::net {

std::string encodeBeacon(const Beacon& b) {
  std::string out;
  auto put = [&](std::uint64_t v, int bytes) {
    for (int i = bytes - 1; i >= 0; --i) out.push_back(static_cast<char>(v >> (8 * i)));
  };
  const auto ecology = std::string_view(b.ecology).substr(0, 255);
  put(kBeaconMagic, 4);
  put(wire::kVersion, 2);
  put(ecology.size(), 1);
  out += ecology;
  put(static_cast<std::uint32_t>(b.id), 4);
  put(b.incarnation, 8);
  put(b.port, 2);
  put((b.wantsAnswer ? 1 : 0) | (b.tool ? 2 : 0) | (b.secured ? 4 : 0), 1);
  return out;
}

std::optional<Beacon> decodeBeacon(std::string_view in) {
  std::size_t pos = 0;
  bool ok = true;
  auto get = [&](int bytes) -> std::uint64_t {
    if (!ok || in.size() - pos < static_cast<std::size_t>(bytes)) {
      ok = false;
      return 0;
    }
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v = (v << 8) | static_cast<std::uint8_t>(in[pos++]);
    return v;
  };
  Beacon b;
  if (get(4) != kBeaconMagic || get(2) != wire::kVersion) return std::nullopt;
  const auto length = get(1);
  if (!ok || in.size() - pos < length) return std::nullopt;
  b.ecology = std::string(in.substr(pos, length));
  pos += length;
  const auto id = static_cast<std::int32_t>(get(4));
  b.incarnation = get(8);
  b.port = static_cast<std::uint16_t>(get(2));
  const auto flags = get(1);
  if (!ok || pos != in.size() || !isValidPeisId(id) || b.port == 0 || flags > 7 ||
      b.ecology.empty()) {
    return std::nullopt;
  }
  b.id = id;
  b.wantsAnswer = (flags & 1) != 0;
  b.tool = (flags & 2) != 0;
  b.secured = (flags & 4) != 0;
  return b;
}

}  // namespace peis::net
