// The PEIS wire protocol, version 3: every frame's byte layout. This header
// is the code-side statement of docs/protocol.md (which is normative); the
// encoder and decoder in wire.cpp follow it field by field.
//
// All integers are big-endian (network byte order); no struct is ever
// copied to or from the wire. Strings carry their length first:
//   str8  = u8 length, bytes        str16 = u16 length, bytes
//   bytes32 = u32 length, bytes (tuple data, at most the frame limit)
//
// Frame (TCP link):
//   u32 length      bytes after this field (1 .. kMaxFrameBytes)
//   u8  type        MessageType
//   ...             the body of that type
//
// Link messages (between two directly linked PEIS):
//   Hello   u32 magic "PEIS" | u16 version | str8 ecology | i32 id |
//           u64 incarnation | str8 name | u16 listen port | u32 capabilities |
//           str16 auth (empty in an open ecology; a secured ecology's
//           HelloAuth, docs/protocol.md §15.4)
//   Ping    u64 nonce          Pong  u64 nonce
//   Routes  u16 count | count x (i32 id | u8 hops | u8 flags | u64 incarnation |
//           u32 seqno | str8 name)
//   IdTaken i32 id | u64 incarnation  (your id is already used: re-pick)
//   Leave   i32 id | u64 incarnation  (that PEIS quit: forget it, pass it on)
//   SeqnoRequest i32 id | u64 incarnation | u32 seqno | u8 hop limit
//                (asks PEIS id for a route seqno of at least `seqno`)
// Secured ecologies only (docs/protocol.md §15), inside the link's records:
//   Auth      str16 identity | 64 bytes signature over the handshake
//   Identity  str16 identity (of a PEIS this one advertises a route to)
//   SourceTag 16 bytes (proves the source of the routed frame after it)
//
// Routed messages start with an envelope: i32 source | i32 destination | u8 ttl
//   Subscribe    u64 subscription | u32 lease ms | u8 has owner | i32 owner |
//                str16 key pattern | u32 known count | u64 known digest |
//                u32 max data (the subscriber's data limit)
//   Unsubscribe  u64 subscription
//   TupleUpdate  u64 owner incarnation | tuple
//   TupleDeleted u64 owner incarnation | i32 owner | str16 key | u64 seqno
//   Write        u64 request | u8 op (0 set, 1 append, 2 erase) |
//                u8 has if-seqno | u64 if-seqno | i64 ttl us |
//                u32 wait ms (how long the writer waits for the result) | tuple
//   WriteResult  u64 request | u8 status (0 ok, else ErrorCode + 1) |
//                u64 seqno | str16 message
//   TupleWithheld u64 owner incarnation | i32 limited by | u32 limit |
//                tuple head (a value over the data limit of PEIS `limited by`)
//   KeyManifest  u64 owner incarnation | u64 subscription | u64 range first |
//                u64 range last | u16 count | count x u64 key hash (ascending,
//                all within the range)
//
// tuple = i32 owner | i32 creator | str16 key | str8 mimetype | u8 encoding |
//         i64 ts_write | i64 ts_user | i64 ts_expire (microseconds since the
//         Unix epoch, 0 = unset) | u64 seqno | bytes32 data
// tuple head = the same without the data bytes (u32 data length still there)
//
// A routed frame whose data is over the receiver's limit (a TupleUpdate or a
// Write) is not dropped: the receiver reads its first kOversizeHeadBytes,
// skips the rest and answers it (docs/protocol.md §2.1).
#pragma once

#include <cstddef>
#include <cstdint>

#include "peis/types.h"

namespace peis::wire {

inline constexpr std::uint32_t kMagic = 0x50454953;  // "PEIS"
inline constexpr std::uint16_t kVersion = 3;
inline constexpr std::size_t kFrameHeaderBytes = 4;
// Largest frame: the largest data any PEIS accepts plus room for the fields.
inline constexpr std::size_t kMaxFrameOverhead = 64 * 1024;
// The longest frame any PEIS may send (the hard data limit plus the fields);
// a longer length is a framing error.
inline constexpr std::size_t kLargestFrameBytes = kMaxDataBytes + kMaxFrameOverhead;
// Bytes of a tuple head at most, with a valid key (256) and mimetype (255):
// owner, creator, str16 key, str8 mimetype, encoding, 3 times, seqno, length.
inline constexpr std::size_t kMaxTupleHeadBytes = 4 + 4 + (2 + 256) + (1 + 255) + 1 + 3 * 8 + 8 + 4;
// The first bytes of an oversized frame that say all but its data: type,
// envelope (9), the Write fields (30; a TupleUpdate's are fewer), tuple head.
inline constexpr std::size_t kOversizeHeadBytes = 1 + 9 + 30 + kMaxTupleHeadBytes;
inline constexpr std::uint8_t kDefaultTtl = 32;
// The longest frame a PEIS takes on a link whose handshake is not complete
// (a Hello, and in a secured ecology an Auth): a connection that has not
// shown who it is costs at most this much buffer.
inline constexpr std::size_t kMaxHandshakeFrameBytes = 8 * 1024;
// Tuple data from this size on is sent from the stored tuple (gathered
// write), not copied into an encoded frame.
inline constexpr std::size_t kZeroCopyDataBytes = 16 * 1024;

enum class MessageType : std::uint8_t {
  Hello = 1,
  Ping = 2,
  Pong = 3,
  Routes = 4,
  IdTaken = 5,
  Leave = 6,
  SeqnoRequest = 7,
  Auth = 8,
  Identity = 9,
  SourceTag = 10,
  Subscribe = 16,
  Unsubscribe = 17,
  TupleUpdate = 18,
  TupleDeleted = 19,
  Write = 20,
  WriteResult = 21,
  TupleWithheld = 22,
  KeyManifest = 23,
};

inline constexpr bool isRouted(MessageType type) { return static_cast<std::uint8_t>(type) >= 16; }

// Subscribe's max data when the subscriber announces no limit.
inline constexpr std::uint32_t kNoDataLimit = 0xffffffff;

// Capability flags in Hello.
inline constexpr std::uint32_t kCapabilityCoalescing = 1u << 0;
inline constexpr std::uint32_t kCapabilityTool = 1u << 1;     // a short-lived tool PEIS
inline constexpr std::uint32_t kCapabilitySecured = 1u << 2;  // a secured ecology's PEIS
inline constexpr std::size_t kSignatureBytes = 64;            // of an Auth
inline constexpr std::size_t kSourceTagBytes = 16;            // of a SourceTag
// Flags of a Routes entry.
inline constexpr std::uint8_t kRouteFlagTool = 1u << 0;  // the PEIS is a tool

}  // namespace peis::wire
