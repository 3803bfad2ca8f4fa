// SourceTags: proof, for a routed frame that other PEIS relay, that it
// comes from the source its envelope names (docs/protocol.md §15.6). A
// link's records prove only which neighbour sent a frame; a frame from
// further away carries a 16-byte tag keyed by the source and destination's
// static keys (X25519 of their Ed25519 keys, as certified), so that no PEIS
// on the way, authenticated or not, can forge or change it.
//
//   key = BLAKE2b("PEIS v3 source tags" | X25519 shared secret | the two
//         public keys in byte order)
//   tag = BLAKE2b-128 keyed by it over the frame without its ttl byte
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "security/credentials.h"

namespace peis::security {

class SourceTags {
 public:
  explicit SourceTags(const Credentials& ours);
  ~SourceTags();
  SourceTags(const SourceTags&) = delete;
  SourceTags& operator=(const SourceTags&) = delete;

  // The tag of a routed frame (its bytes after the length field) between us
  // and the holder of `theirKey`; `tail` is the frame's last bytes when
  // they are not in `frame` (a big tuple's data, written from where it is).
  std::string tag(std::string_view theirKey, std::string_view frame, std::string_view tail = {});
  bool check(std::string_view theirKey, std::string_view tag, std::string_view frame);
  static constexpr std::size_t kTagBytes = 16;

 private:
  const std::string& pairKey(std::string_view theirKey);
  std::string ourKey_;                                        // Ed25519 public
  std::string ourCurve_;                                      // X25519 secret
  std::map<std::string, std::string, std::less<>> pairKeys_;  // theirs -> key
};

}  // namespace peis::security
