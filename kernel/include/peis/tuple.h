// The tuple: <owner, key, data> plus the meta data of tiny-peis-kernel.txt
// Fig. 4. A plain value type; the owner stamps ts_write and seqno.
#pragma once

#include <cstdint>
#include <string>

#include "peis/types.h"

namespace peis {

inline constexpr const char* kDefaultMimetype = "text/plain";
inline constexpr const char* kMetaMimetype = "application/x-peis-meta";

struct Tuple {
  PeisId owner = 0;    // the PEIS whose namespace holds the key
  PeisId creator = 0;  // the PEIS that made the write
  std::string key;     // dotted, e.g. "position.x"
  std::string data;    // bytes; text when encoding is Ascii
  std::string mimetype = kDefaultMimetype;
  Encoding encoding = Encoding::Ascii;
  Timestamp ts_write = kNoTime;   // stamped by the owner on acceptance
  Timestamp ts_user = kNoTime;    // free for the writer (e.g. sample time)
  Timestamp ts_expire = kNoTime;  // kNoTime: never expires
  std::uint64_t seqno = 0;        // owner-assigned, increasing per key

  std::string fullName() const;
  bool isExpiredAt(Timestamp now) const { return ts_expire != kNoTime && ts_expire <= now; }
  bool operator==(const Tuple&) const = default;
};

}  // namespace peis

namespace peis {

// What a writer may say about a write besides key and data.
struct WriteOptions {
  std::string mimetype = kDefaultMimetype;
  Encoding encoding = Encoding::Ascii;
  Timestamp ts_user = kNoTime;
  // Absolute expiry; wins over `ttl` when both are set.
  Timestamp ts_expire = kNoTime;
  // Expiry relative to the owner's acceptance time (0: never).
  std::chrono::microseconds ttl{0};
};

// Names one tuple: (owner, key).
struct TupleRef {
  PeisId owner = 0;
  std::string key;
  auto operator<=>(const TupleRef&) const = default;
  std::string str() const;
};

}  // namespace peis
