// Encoding and decoding of wire frames (layout in wire_format.h and
// docs/protocol.md). Pure functions on bytes: the decoder checks every
// length and field and returns a reason instead of ever reading past the
// input or accepting an invalid value.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "net/wire_format.h"
#include "peis/tuple.h"

namespace peis::wire {

struct Hello {
  std::uint16_t version = kVersion;
  std::string ecology;
  PeisId id = 0;
  std::uint64_t incarnation = 0;
  std::string name;
  std::uint16_t listenPort = 0;
  std::uint32_t capabilities = 0;
  std::string auth;
  bool operator==(const Hello&) const = default;
};
struct Ping {
  std::uint64_t nonce = 0;
  bool operator==(const Ping&) const = default;
};
struct Pong {
  std::uint64_t nonce = 0;
  bool operator==(const Pong&) const = default;
};
struct RouteEntry {
  PeisId id = 0;
  std::uint8_t hops = 0;
  std::uint8_t flags = 0;  // kRouteFlagTool
  std::uint64_t incarnation = 0;
  std::uint32_t seqno = 0;  // the route's sequence number, set by `id` (docs/protocol.md §8)
  std::string name;
  bool operator==(const RouteEntry&) const = default;
};
struct Routes {
  std::vector<RouteEntry> entries;
  bool operator==(const Routes&) const = default;
};
struct IdTaken {
  PeisId id = 0;
  std::uint64_t incarnation = 0;
  bool operator==(const IdTaken&) const = default;
};
struct Leave {
  PeisId id = 0;  // the PEIS that left (flooded: not always the sender)
  std::uint64_t incarnation = 0;
  bool operator==(const Leave&) const = default;
};
struct SeqnoRequest {
  PeisId id = 0;  // the PEIS asked for a newer route seqno
  std::uint64_t incarnation = 0;
  std::uint32_t seqno = 0;  // at least this one
  std::uint8_t hopLimit = 0;
  bool operator==(const SeqnoRequest&) const = default;
};

// Secured ecologies (docs/protocol.md §15): the proof of who a link's peer
// is, the identities passed on with routes, the tag of a relayed frame.
struct Auth {
  std::string identity;   // security::encodeIdentity
  std::string signature;  // kSignatureBytes, over the handshake's transcript
  bool operator==(const Auth&) const = default;
};
struct Identity {
  std::string identity;
  bool operator==(const Identity&) const = default;
};
struct SourceTag {
  std::string tag;  // kSourceTagBytes
  bool operator==(const SourceTag&) const = default;
};

struct Envelope {
  PeisId source = 0;
  PeisId destination = 0;
  std::uint8_t ttl = kDefaultTtl;
  bool operator==(const Envelope&) const = default;
};
struct Subscribe {
  std::uint64_t subscription = 0;
  std::uint32_t leaseMs = 0;
  std::optional<PeisId> owner;
  std::string keyPattern;
  // What the subscriber already holds of the owner's matching tuples: how
  // many, and their digest (tupleDigest summed). An owner whose own count or
  // digest differs sends everything again, with a KeyManifest (anti-entropy
  // for values and deletions lost in transit).
  std::uint32_t knownCount = 0;
  std::uint64_t knownDigest = 0;
  // The subscriber's data limit: a value over it is sent as TupleWithheld.
  std::uint32_t maxDataBytes = kNoDataLimit;
  bool operator==(const Subscribe&) const = default;
};
struct Unsubscribe {
  std::uint64_t subscription = 0;
  bool operator==(const Unsubscribe&) const = default;
};
struct TupleUpdate {
  std::uint64_t ownerIncarnation = 0;
  Tuple tuple;
  bool operator==(const TupleUpdate&) const = default;
};
struct TupleDeleted {
  std::uint64_t ownerIncarnation = 0;
  PeisId owner = 0;
  std::string key;
  std::uint64_t seqno = 0;
  bool operator==(const TupleDeleted&) const = default;
};
enum class WriteOp : std::uint8_t { Set = 0, Append = 1, Erase = 2 };
struct Write {
  std::uint64_t request = 0;
  WriteOp op = WriteOp::Set;
  std::optional<std::uint64_t> ifSeqno;
  std::int64_t ttlMicros = 0;
  Tuple tuple;  // owner, key, data, mimetype, encoding, ts_user, ts_expire
  // How long the writer waits for the result (0: unknown). An owner that
  // holds the write (a write gate) answers before then. (On the wire it
  // comes before the tuple.)
  std::uint32_t waitMs = 0;
  bool operator==(const Write&) const = default;
};
struct WriteResult {
  std::uint64_t request = 0;
  std::uint8_t status = 0;  // 0 ok, else ErrorCode + 1
  std::uint64_t seqno = 0;
  std::string message;
  bool operator==(const WriteResult&) const = default;
};

// In place of a TupleUpdate whose value is over a PEIS's data limit: the
// tuple without its data. Sent by the owner to a subscriber whose limit it
// knows, or by the PEIS on the way whose limit the value is over.
struct TupleWithheld {
  std::uint64_t ownerIncarnation = 0;
  PeisId limitedBy = 0;     // the PEIS whose limit the value is over
  std::uint32_t limit = 0;  // that PEIS's --peis-max-data
  std::uint32_t dataBytes = 0;
  Tuple tuple;  // every field but the data (empty)
  bool operator==(const TupleWithheld&) const = default;
};

// After a full sync, the keys the owner holds that the subscription
// matches, as keyHash values in ascending order, one hash range at a time:
// the subscriber drops what it holds of the owner in [rangeFirst, rangeLast]
// that the list does not name (a deletion it missed).
struct KeyManifest {
  std::uint64_t ownerIncarnation = 0;
  std::uint64_t subscription = 0;
  std::uint64_t rangeFirst = 0;
  std::uint64_t rangeLast = 0;
  std::vector<std::uint64_t> keyHashes;
  bool operator==(const KeyManifest&) const = default;
};
// Most hashes in one KeyManifest (16 KiB of them).
inline constexpr std::size_t kMaxManifestHashes = 2048;

// The hash of a key in a KeyManifest and a digest: 64-bit FNV-1a.
std::uint64_t keyHash(std::string_view key);
// One tuple's share of a Subscribe's known digest (the digest is the sum).
std::uint64_t tupleDigest(std::string_view key, std::uint64_t seqno);

using LinkMessage = std::variant<Hello, Ping, Pong, Routes, IdTaken, Leave, SeqnoRequest, Auth,
                                 Identity, SourceTag>;
using RoutedBody = std::variant<Subscribe, Unsubscribe, TupleUpdate, TupleDeleted, Write,
                                WriteResult, TupleWithheld, KeyManifest>;
struct RoutedMessage {
  Envelope envelope;
  RoutedBody body;
  bool operator==(const RoutedMessage&) const = default;
};
using Message = std::variant<LinkMessage, RoutedMessage>;

// Appends one whole frame (length prefix included) to `out`.
void encode(const LinkMessage& message, std::string& out);
void encode(const RoutedMessage& message, std::string& out);
// The frame for a routed body with its envelope; the body bytes are built
// once and can be re-enveloped per destination with reEnvelope().
std::string encodeFrame(const RoutedMessage& message);
// A TupleUpdate frame straight from a stored tuple (no intermediate copy),
// appended to `out`; tupleUpdateFrameBytes() is its size, length included.
// With TupleData::Omit the data bytes are left out (the length field still
// counts them): the caller sends tuple.data right after, from where it is.
enum class TupleData { Include, Omit };
std::size_t tupleUpdateFrameBytes(const Tuple& tuple);
// `frameBytes`: tupleUpdateFrameBytes(tuple) when the caller has it (0: computed).
void encodeTupleUpdate(const Envelope& envelope, std::uint64_t ownerIncarnation, const Tuple& tuple,
                       std::string& out, TupleData data = TupleData::Include,
                       std::size_t frameBytes = 0);
// Encodes the TupleUpdate frames of a stream to one destination: the fields
// that repeat from one update of a tuple to the next (type, envelope, owner
// incarnation, owner, creator, key, mimetype, encoding) are encoded once and
// copied into each frame as bytes while they stay the same. The frames are
// exactly encodeTupleUpdate's.
class TupleUpdateEncoder {
 public:
  // Appends the frame of `tuple` to `out`.
  void append(const Envelope& envelope, std::uint64_t ownerIncarnation, const Tuple& tuple,
              std::string& out);
  // Writes the frame of `tuple` at `at`, where tupleUpdateFrameBytes(tuple)
  // bytes are free (the caller sized its buffer without filling it).
  void write(const Envelope& envelope, std::uint64_t ownerIncarnation, const Tuple& tuple,
             char* at);

 private:
  bool repeats(const Envelope& envelope, std::uint64_t ownerIncarnation, const Tuple& tuple) const;
  std::string head_;  // the repeated fields as encoded, the type byte first; empty: none yet
  Envelope envelope_;
  std::uint64_t ownerIncarnation_ = 0;
  PeisId owner_ = 0;
  PeisId creator_ = 0;
  Encoding encoding_ = Encoding::Ascii;
  std::size_t keyBytes_ = 0;
};
// Rewrites the envelope of an encoded routed frame in place.
void reEnvelope(std::string& frame, const Envelope& envelope);

struct DecodeResult {
  std::optional<Message> message;
  std::string error;  // why the frame was rejected, when message is empty
};
// Decodes the bytes of one frame after the u32 length field (type + body).
// `maxDataBytes` bounds tuple data.
DecodeResult decode(std::string_view frame, std::size_t maxDataBytes);

// Decodes a routed frame into `out`, reusing its memory (the receive hot
// path); false with the reason in `error` for anything decode() rejects.
bool decodeRouted(std::string_view frame, std::size_t maxDataBytes, RoutedMessage& out,
                  std::string& error);
// The beginning of a big TupleUpdate frame whose data is then read straight
// into place (net/link.h, "placed frames"): `head` is what has arrived of a
// frame of `frameLength` bytes (type and body, without the length prefix).
// True when `head` holds every field before the data of a well-formed
// TupleUpdate whose data is within `maxDataBytes` and ends the frame: `out`
// then holds the update but its data (left as it was), and `dataAt` is
// where in the frame the data begins. False for anything else, which is
// then read whole and decoded (or rejected) by decodeRouted().
bool decodeTupleUpdateHead(std::string_view head, std::size_t frameLength, std::size_t maxDataBytes,
                           RoutedMessage& out, std::size_t& dataAt);
// Whether the frame's type byte names a routed message.
bool isRoutedFrame(std::string_view frame);

// Reads the u32 length prefix at the start of `bytes` (needs 4 bytes).
// Inline: the link reads one per frame.
inline std::uint32_t frameLength(std::string_view bytes) {
  std::uint32_t v;
  std::memcpy(&v, bytes.data(), 4);
  if constexpr (std::endian::native == std::endian::little) v = __builtin_bswap32(v);
  return v;
}

// A routed frame whose tuple data is over this PEIS's limit: what its first
// bytes say, enough to answer it (docs/protocol.md §2.1).
struct Oversize {
  Envelope envelope;
  MessageType type = MessageType::TupleUpdate;  // or Write
  std::uint64_t request = 0;                    // of a Write
  std::uint64_t ownerIncarnation = 0;           // of a TupleUpdate
  std::uint32_t dataBytes = 0;
  Tuple tuple;  // every field before the data; the data is empty
};
// Decodes the first min(frame length, kOversizeHeadBytes) bytes of a frame
// (after the length field). nullopt unless they begin a well-formed
// TupleUpdate or Write whose data is over `maxDataBytes` (anything else is
// malformed).
std::optional<Oversize> decodeOversize(std::string_view head, std::size_t maxDataBytes);
// The answer of PEIS `self` (limit `maxDataBytes`) to an oversized frame, for
// itself or another PEIS: to a Write, a TooLarge WriteResult for the writer;
// to a TupleUpdate, a TupleWithheld for its destination.
RoutedMessage answerOversize(const Oversize& oversize, PeisId self, std::size_t maxDataBytes);

}  // namespace peis::wire
