// Wire frame encoder and checked decoder; layout in wire_format.h.
#include "net/wire.h"

#include <bit>
#include <cstring>

#include "peis/error.h"
#include "peis/key.h"
#include "same_bytes.h"

namespace peis::wire {
namespace {

// Big-endian integers of n = 1, 2, 4 or 8 bytes (n is a constant where
// these are inlined, so each becomes one load or store and a byte swap).
inline std::uint64_t readBigEndian(const char* p, int n) {
  std::uint64_t v = 0;
  if constexpr (std::endian::native == std::endian::little) {
    switch (n) {
      case 8:
        std::memcpy(&v, p, 8);
        return __builtin_bswap64(v);
      case 4: {
        std::uint32_t x;
        std::memcpy(&x, p, 4);
        return __builtin_bswap32(x);
      }
      case 2: {
        std::uint16_t x;
        std::memcpy(&x, p, 2);
        return __builtin_bswap16(x);
      }
      default:
        break;
    }
  }
  for (int i = 0; i < n; ++i) v = (v << 8) | static_cast<std::uint8_t>(p[i]);
  return v;
}

inline void writeBigEndian(char* p, std::uint64_t v, int n) {
  if constexpr (std::endian::native == std::endian::little) {
    switch (n) {
      case 8: {
        const auto x = __builtin_bswap64(v);
        std::memcpy(p, &x, 8);
        return;
      }
      case 4: {
        const auto x = __builtin_bswap32(static_cast<std::uint32_t>(v));
        std::memcpy(p, &x, 4);
        return;
      }
      case 2: {
        const auto x = __builtin_bswap16(static_cast<std::uint16_t>(v));
        std::memcpy(p, &x, 2);
        return;
      }
      default:
        break;
    }
  }
  for (int i = 0; i < n; ++i) p[i] = static_cast<char>(v >> (8 * (n - 1 - i)));
}

class Writer {
 public:
  explicit Writer(std::string& out) : out_(out) {}
  void u8(std::uint8_t v) { out_.push_back(static_cast<char>(v)); }
  void u16(std::uint16_t v) { put(v, 2); }
  void u32(std::uint32_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  void str8(std::string_view s) {
    u8(static_cast<std::uint8_t>(std::min<std::size_t>(s.size(), 255)));
    out_.append(s.substr(0, 255));
  }
  void str16(std::string_view s) {
    u16(static_cast<std::uint16_t>(std::min<std::size_t>(s.size(), 65535)));
    out_.append(s.substr(0, 65535));
  }
  void raw(std::string_view s) { out_.append(s); }

 private:
  // The low `n` bytes of `v`, most significant first, in one append.
  void put(std::uint64_t v, int n) {
    char bytes[8];
    for (int i = 0; i < n; ++i) bytes[i] = static_cast<char>(v >> (8 * (n - 1 - i)));
    out_.append(bytes, static_cast<std::size_t>(n));
  }
  std::string& out_;
};

// Copies `n` bytes of a tuple's field. GCC turns a memcpy whose size it
// knows to be small (a key or mimetype cut at 255) into `rep movsq`, whose
// start-up costs more than the copy (about 4 % of a 16-byte stream's CPU):
// up to 32 bytes go in two overlapping moves, more through a call to memcpy
// with what the compiler knew of the size hidden.
inline void copyField(char* to, const char* from, std::size_t n) {
  if (n >= 16 && n <= 32) {
    std::memcpy(to, from, 16);
    std::memcpy(to + n - 16, from + n - 16, 16);
  } else if (n >= 8 && n < 16) {
    std::memcpy(to, from, 8);
    std::memcpy(to + n - 8, from + n - 8, 8);
  } else if (n >= 4 && n < 8) {
    std::memcpy(to, from, 4);
    std::memcpy(to + n - 4, from + n - 4, 4);
  } else if (n > 0 && n < 4) {
    to[0] = from[0];
    to[n / 2] = from[n / 2];
    to[n - 1] = from[n - 1];
  } else if (n > 32) {
    asm("" : "+r"(n));
    std::memcpy(to, from, n);
  }
}

// Writes into memory already sized for the fields (the hot TupleUpdate path).
class RawWriter {
 public:
  explicit RawWriter(char* at) : p_(at) {}
  void u8(std::uint8_t v) { *p_++ = static_cast<char>(v); }
  void u16(std::uint16_t v) { put(v, 2); }
  void u32(std::uint32_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  void str8(std::string_view s) {
    s = s.substr(0, 255);
    u8(static_cast<std::uint8_t>(s.size()));
    raw(s);
  }
  void str16(std::string_view s) {
    s = s.substr(0, 65535);
    u16(static_cast<std::uint16_t>(s.size()));
    raw(s);
  }
  void raw(std::string_view s) {
    copyField(p_, s.data(), s.size());
    p_ += s.size();
  }
  char* at() const { return p_; }

 private:
  void put(std::uint64_t v, int n) {
    writeBigEndian(p_, v, n);
    p_ += n;
  }
  char* p_;
};

// Reads fields with bounds checks; the first failure sticks and names itself.
// The checks are inline; building the reason is out of line (cold).
class Reader {
 public:
  explicit Reader(std::string_view in) : in_(in) {}
  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }
  [[gnu::cold, gnu::noinline]] void fail(std::string why) {
    if (ok_) error_ = std::move(why);
    ok_ = false;
  }
  bool need(std::size_t n, const char* what) {
    if (!ok_) [[unlikely]]
      return false;
    if (in_.size() - pos_ < n) [[unlikely]] {
      truncated(what);
      return false;
    }
    return true;
  }
  std::uint8_t u8(const char* what) {
    if (!need(1, what)) return 0;
    return static_cast<std::uint8_t>(in_[pos_++]);
  }
  std::uint16_t u16(const char* what) { return static_cast<std::uint16_t>(get(2, what)); }
  std::uint32_t u32(const char* what) { return static_cast<std::uint32_t>(get(4, what)); }
  std::uint64_t u64(const char* what) { return get(8, what); }
  std::int32_t i32(const char* what) { return static_cast<std::int32_t>(u32(what)); }
  std::int64_t i64(const char* what) { return static_cast<std::int64_t>(u64(what)); }
  std::string bytes(std::size_t n, const char* what) {
    if (!need(n, what)) return {};
    std::string s(in_.substr(pos_, n));
    pos_ += n;
    return s;
  }
  std::string str8(const char* what) { return bytes(u8(what), what); }
  std::string str16(const char* what) { return bytes(u16(what), what); }
  // Into an existing string (its memory is reused).
  void bytesInto(std::string& s, std::size_t n, const char* what) {
    if (!need(n, what)) return s.clear();
    s.assign(in_.data() + pos_, n);
    pos_ += n;
  }
  PeisId id(const char* what) {
    const auto v = i32(what);
    if (ok_ && !isValidPeisId(v)) [[unlikely]]
      invalid(what, v);
    return v;
  }
  std::size_t position() const { return pos_; }
  void end() {
    if (ok_ && pos_ != in_.size()) {
      fail(std::to_string(in_.size() - pos_) + " unexpected trailing bytes");
    }
  }

 private:
  std::uint64_t get(int n, const char* what) {
    if (!need(static_cast<std::size_t>(n), what)) return 0;
    const auto v = readBigEndian(in_.data() + pos_, n);
    pos_ += static_cast<std::size_t>(n);
    return v;
  }
  [[gnu::cold, gnu::noinline]] void truncated(const char* what) {
    fail(std::string("truncated ") + what);
  }
  [[gnu::cold, gnu::noinline]] void invalid(const char* what, std::int32_t v) {
    fail(std::string("invalid ") + what + " " + std::to_string(v));
  }
  std::string_view in_;
  std::size_t pos_ = 0;
  bool ok_ = true;
  std::string error_;
};

std::int64_t micros(Timestamp t) { return t.time_since_epoch().count(); }
Timestamp fromMicros(std::int64_t v) { return Timestamp(std::chrono::microseconds(v)); }

// The tuple's fields, for the growing Writer and the in-place RawWriter.
// Every field up to the data length (the data bytes come last).
template <typename W>
void writeTupleHead(W& w, const Tuple& t, std::uint32_t dataBytes) {
  w.i32(t.owner);
  w.i32(t.creator);
  w.str16(t.key);
  w.str8(t.mimetype);
  w.u8(static_cast<std::uint8_t>(t.encoding));
  w.i64(micros(t.ts_write));
  w.i64(micros(t.ts_user));
  w.i64(micros(t.ts_expire));
  w.u64(t.seqno);
  w.u32(dataBytes);
}

template <typename W>
void writeTuple(W& w, const Tuple& t) {
  writeTupleHead(w, t, static_cast<std::uint32_t>(t.data.size()));
  w.raw(t.data);
}

void checkKey(Reader& r, const std::string& key, const char* what) {
  if (!r.ok()) return;
  if (auto problem = keyProblem(key)) r.fail(std::string("bad ") + what + ": " + *problem);
}

// Every field of a tuple up to its data; returns the data length.
std::uint32_t readTupleHead(Reader& r, Tuple& t) {
  t.owner = r.id("tuple owner");
  t.creator = r.id("tuple creator");
  r.bytesInto(t.key, r.u16("tuple key"), "tuple key");
  // A stream repeats one key: the last key that passed is not checked again.
  thread_local std::string lastGoodKey;
  if (r.ok() && t.key != lastGoodKey) {
    checkKey(r, t.key, "tuple key");
    if (r.ok()) lastGoodKey = t.key;
  }
  r.bytesInto(t.mimetype, r.u8("mimetype"), "mimetype");
  const auto encoding = r.u8("encoding");
  if (r.ok() && encoding > 1) r.fail("unknown encoding " + std::to_string(encoding));
  t.encoding = static_cast<Encoding>(encoding);
  t.ts_write = fromMicros(r.i64("ts_write"));
  t.ts_user = fromMicros(r.i64("ts_user"));
  t.ts_expire = fromMicros(r.i64("ts_expire"));
  t.seqno = r.u64("seqno");
  return r.u32("data length");
}

void readTupleInto(Reader& r, std::size_t maxDataBytes, Tuple& t) {
  const auto size = readTupleHead(r, t);
  if (r.ok() && size > maxDataBytes) {
    r.fail("data of " + std::to_string(size) + " bytes exceeds the limit of " +
           std::to_string(maxDataBytes));
  }
  r.bytesInto(t.data, size, "data");
}

Tuple readTuple(Reader& r, std::size_t maxDataBytes) {
  Tuple t;
  readTupleInto(r, maxDataBytes, t);
  return t;
}

void beginFrame(std::string& out, MessageType type, std::size_t& start) {
  start = out.size();
  out.append(4, '\0');
  out.push_back(static_cast<char>(type));
}

void endFrame(std::string& out, std::size_t start) {
  const auto length = static_cast<std::uint32_t>(out.size() - start - 4);
  for (int i = 0; i < 4; ++i) out[start + i] = static_cast<char>(length >> (24 - 8 * i));
}

struct LinkEncoder {
  std::string& out;
  void operator()(const Hello& m) {
    std::size_t start;
    beginFrame(out, MessageType::Hello, start);
    Writer w(out);
    w.u32(kMagic);
    w.u16(m.version);
    w.str8(m.ecology);
    w.i32(m.id);
    w.u64(m.incarnation);
    w.str8(m.name);
    w.u16(m.listenPort);
    w.u32(m.capabilities);
    w.str16(m.auth);
    endFrame(out, start);
  }
  void operator()(const Ping& m) { nonce(MessageType::Ping, m.nonce); }
  void operator()(const Pong& m) { nonce(MessageType::Pong, m.nonce); }
  void operator()(const Routes& m) {
    std::size_t start;
    beginFrame(out, MessageType::Routes, start);
    Writer w(out);
    const auto count = std::min<std::size_t>(m.entries.size(), 65535);
    w.u16(static_cast<std::uint16_t>(count));
    for (std::size_t i = 0; i < count; ++i) {
      const auto& e = m.entries[i];
      w.i32(e.id);
      w.u8(e.hops);
      w.u8(e.flags);
      w.u64(e.incarnation);
      w.u32(e.seqno);
      w.str8(e.name);
    }
    endFrame(out, start);
  }
  void operator()(const IdTaken& m) {
    std::size_t start;
    beginFrame(out, MessageType::IdTaken, start);
    Writer w(out);
    w.i32(m.id);
    w.u64(m.incarnation);
    endFrame(out, start);
  }
  void operator()(const Leave& m) {
    std::size_t start;
    beginFrame(out, MessageType::Leave, start);
    Writer w(out);
    w.i32(m.id);
    w.u64(m.incarnation);
    endFrame(out, start);
  }
  void operator()(const SeqnoRequest& m) {
    std::size_t start;
    beginFrame(out, MessageType::SeqnoRequest, start);
    Writer w(out);
    w.i32(m.id);
    w.u64(m.incarnation);
    w.u32(m.seqno);
    w.u8(m.hopLimit);
    endFrame(out, start);
  }
  void operator()(const Auth& m) {
    std::size_t start;
    beginFrame(out, MessageType::Auth, start);
    Writer w(out);
    w.str16(m.identity);
    w.raw(m.signature);
    endFrame(out, start);
  }
  void operator()(const Identity& m) {
    std::size_t start;
    beginFrame(out, MessageType::Identity, start);
    Writer(out).str16(m.identity);
    endFrame(out, start);
  }
  void operator()(const SourceTag& m) {
    std::size_t start;
    beginFrame(out, MessageType::SourceTag, start);
    Writer(out).raw(m.tag);
    endFrame(out, start);
  }
  void nonce(MessageType type, std::uint64_t value) {
    std::size_t start;
    beginFrame(out, type, start);
    Writer(out).u64(value);
    endFrame(out, start);
  }
};

MessageType typeOf(const RoutedBody& body) {
  struct {
    MessageType operator()(const Subscribe&) { return MessageType::Subscribe; }
    MessageType operator()(const Unsubscribe&) { return MessageType::Unsubscribe; }
    MessageType operator()(const TupleUpdate&) { return MessageType::TupleUpdate; }
    MessageType operator()(const TupleDeleted&) { return MessageType::TupleDeleted; }
    MessageType operator()(const Write&) { return MessageType::Write; }
    MessageType operator()(const WriteResult&) { return MessageType::WriteResult; }
    MessageType operator()(const TupleWithheld&) { return MessageType::TupleWithheld; }
    MessageType operator()(const KeyManifest&) { return MessageType::KeyManifest; }
  } visitor;
  return std::visit(visitor, body);
}

struct BodyEncoder {
  Writer& w;
  void operator()(const Subscribe& m) {
    w.u64(m.subscription);
    w.u32(m.leaseMs);
    w.u8(m.owner ? 1 : 0);
    w.i32(m.owner.value_or(0));
    w.str16(m.keyPattern);
    w.u32(m.knownCount);
    w.u64(m.knownDigest);
    w.u32(m.maxDataBytes);
  }
  void operator()(const Unsubscribe& m) { w.u64(m.subscription); }
  void operator()(const TupleUpdate& m) {
    w.u64(m.ownerIncarnation);
    writeTuple(w, m.tuple);
  }
  void operator()(const TupleDeleted& m) {
    w.u64(m.ownerIncarnation);
    w.i32(m.owner);
    w.str16(m.key);
    w.u64(m.seqno);
  }
  void operator()(const Write& m) {
    w.u64(m.request);
    w.u8(static_cast<std::uint8_t>(m.op));
    w.u8(m.ifSeqno ? 1 : 0);
    w.u64(m.ifSeqno.value_or(0));
    w.i64(m.ttlMicros);
    w.u32(m.waitMs);
    writeTuple(w, m.tuple);
  }
  void operator()(const WriteResult& m) {
    w.u64(m.request);
    w.u8(m.status);
    w.u64(m.seqno);
    w.str16(m.message);
  }
  void operator()(const TupleWithheld& m) {
    w.u64(m.ownerIncarnation);
    w.i32(m.limitedBy);
    w.u32(m.limit);
    writeTupleHead(w, m.tuple, m.dataBytes);
  }
  void operator()(const KeyManifest& m) {
    w.u64(m.ownerIncarnation);
    w.u64(m.subscription);
    w.u64(m.rangeFirst);
    w.u64(m.rangeLast);
    w.u16(static_cast<std::uint16_t>(m.keyHashes.size()));
    for (const auto hash : m.keyHashes) w.u64(hash);
  }
};

void writeEnvelope(Writer& w, const Envelope& e) {
  w.i32(e.source);
  w.i32(e.destination);
  w.u8(e.ttl);
}

LinkMessage decodeLink(MessageType type, Reader& r) {
  switch (type) {
    case MessageType::Hello: {
      Hello m;
      if (r.u32("magic") != kMagic && r.ok()) r.fail("bad magic");
      m.version = r.u16("version");
      m.ecology = r.str8("ecology");
      m.id = r.id("PEIS id");
      m.incarnation = r.u64("incarnation");
      m.name = r.str8("name");
      m.listenPort = r.u16("listen port");
      m.capabilities = r.u32("capabilities");
      m.auth = r.str16("auth");
      if (r.ok() && m.ecology.empty()) r.fail("empty ecology name");
      if (r.ok() && !m.name.empty() && nameProblem(m.name)) r.fail("bad PEIS name");
      return m;
    }
    case MessageType::Ping:
      return Ping{r.u64("nonce")};
    case MessageType::Pong:
      return Pong{r.u64("nonce")};
    case MessageType::Routes: {
      Routes m;
      const auto count = r.u16("route count");
      for (std::uint16_t i = 0; i < count && r.ok(); ++i) {
        RouteEntry e;
        e.id = r.id("route id");
        e.hops = r.u8("hops");
        e.flags = r.u8("route flags");
        e.incarnation = r.u64("incarnation");
        e.seqno = r.u32("route seqno");
        e.name = r.str8("route name");
        if (r.ok() && !e.name.empty() && nameProblem(e.name)) r.fail("bad PEIS name in route");
        m.entries.push_back(std::move(e));
      }
      return m;
    }
    case MessageType::Leave: {
      Leave m;
      m.id = r.id("leaving id");
      m.incarnation = r.u64("incarnation");
      return m;
    }
    case MessageType::SeqnoRequest: {
      SeqnoRequest m;
      m.id = r.id("requested id");
      m.incarnation = r.u64("incarnation");
      m.seqno = r.u32("seqno");
      m.hopLimit = r.u8("hop limit");
      return m;
    }
    case MessageType::Auth: {
      Auth m;
      m.identity = r.str16("identity");
      m.signature = r.bytes(kSignatureBytes, "signature");
      return m;
    }
    case MessageType::Identity:
      return Identity{r.str16("identity")};
    case MessageType::SourceTag:
      return SourceTag{r.bytes(kSourceTagBytes, "source tag")};
    default: {
      IdTaken m;
      m.id = r.id("taken id");
      m.incarnation = r.u64("incarnation");
      return m;
    }
  }
}

RoutedBody decodeBody(MessageType type, Reader& r, std::size_t maxDataBytes) {
  switch (type) {
    case MessageType::Subscribe: {
      Subscribe m;
      m.subscription = r.u64("subscription");
      m.leaseMs = r.u32("lease");
      const auto hasOwner = r.u8("owner flag");
      const auto owner = r.i32("owner");
      if (r.ok() && hasOwner > 1) r.fail("bad owner flag");
      if (r.ok() && hasOwner) {
        if (!isValidPeisId(owner)) r.fail("invalid subscription owner");
        m.owner = owner;
      }
      m.keyPattern = r.str16("key pattern");
      m.knownCount = r.u32("known count");
      m.knownDigest = r.u64("known digest");
      m.maxDataBytes = r.u32("max data");
      if (r.ok()) {
        if (auto problem = keyPatternProblem(m.keyPattern)) r.fail("bad key pattern: " + *problem);
      }
      return m;
    }
    case MessageType::Unsubscribe:
      return Unsubscribe{r.u64("subscription")};
    case MessageType::TupleUpdate: {
      TupleUpdate m;
      m.ownerIncarnation = r.u64("incarnation");
      m.tuple = readTuple(r, maxDataBytes);
      return m;
    }
    case MessageType::TupleDeleted: {
      TupleDeleted m;
      m.ownerIncarnation = r.u64("incarnation");
      m.owner = r.id("owner");
      m.key = r.str16("key");
      checkKey(r, m.key, "key");
      m.seqno = r.u64("seqno");
      return m;
    }
    case MessageType::Write: {
      Write m;
      m.request = r.u64("request");
      const auto op = r.u8("op");
      if (r.ok() && op > 2) r.fail("unknown write op " + std::to_string(op));
      m.op = static_cast<WriteOp>(op);
      const auto hasIf = r.u8("if-seqno flag");
      const auto ifSeqno = r.u64("if-seqno");
      if (r.ok() && hasIf > 1) r.fail("bad if-seqno flag");
      if (hasIf == 1) m.ifSeqno = ifSeqno;
      m.ttlMicros = r.i64("ttl");
      if (r.ok() && m.ttlMicros < 0) r.fail("negative ttl");
      m.waitMs = r.u32("wait");
      m.tuple = readTuple(r, maxDataBytes);
      return m;
    }
    case MessageType::TupleWithheld: {
      TupleWithheld m;
      m.ownerIncarnation = r.u64("incarnation");
      m.limitedBy = r.id("limited by");
      m.limit = r.u32("limit");
      m.dataBytes = readTupleHead(r, m.tuple);
      return m;
    }
    case MessageType::KeyManifest: {
      KeyManifest m;
      m.ownerIncarnation = r.u64("incarnation");
      m.subscription = r.u64("subscription");
      m.rangeFirst = r.u64("range first");
      m.rangeLast = r.u64("range last");
      const auto count = r.u16("key hash count");
      if (r.ok() && count > kMaxManifestHashes) r.fail("too many key hashes");
      if (r.ok() && m.rangeFirst > m.rangeLast) r.fail("empty key hash range");
      for (std::uint32_t i = 0; r.ok() && i < count; ++i) {
        const auto hash = r.u64("key hash");
        if (!r.ok()) break;
        if (hash < m.rangeFirst || hash > m.rangeLast) r.fail("key hash outside its range");
        if (!m.keyHashes.empty() && hash <= m.keyHashes.back()) r.fail("key hashes not ascending");
        m.keyHashes.push_back(hash);
      }
      return m;
    }
    default: {
      WriteResult m;
      m.request = r.u64("request");
      m.status = r.u8("status");
      m.seqno = r.u64("seqno");
      m.message = r.str16("message");
      return m;
    }
  }
}

bool knownType(std::uint8_t type) {
  return (type >= 1 && type <= 10) || (type >= 16 && type <= 23);
}

}  // namespace

std::uint64_t keyHash(std::string_view key) {
  std::uint64_t hash = 0xcbf29ce484222325ull;  // FNV-1a, 64 bits
  for (const unsigned char c : key) {
    hash ^= c;
    hash *= 0x100000001b3ull;
  }
  return hash;
}

std::uint64_t tupleDigest(std::string_view key, std::uint64_t seqno) {
  std::uint64_t z = keyHash(key) + seqno * 0x9e3779b97f4a7c15ull;  // splitmix64's finalizer
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

void encode(const LinkMessage& message, std::string& out) { std::visit(LinkEncoder{out}, message); }

void encode(const RoutedMessage& message, std::string& out) {
  std::size_t start;
  beginFrame(out, typeOf(message.body), start);
  Writer w(out);
  writeEnvelope(w, message.envelope);
  std::visit(BodyEncoder{w}, message.body);
  endFrame(out, start);
}

std::size_t tupleUpdateFrameBytes(const Tuple& tuple) {
  // length, type, envelope (9), incarnation (8), tuple (48 + K + M + D).
  return kFrameHeaderBytes + 1 + 9 + 8 + 48 + std::min<std::size_t>(tuple.key.size(), 65535) +
         std::min<std::size_t>(tuple.mimetype.size(), 255) + tuple.data.size();
}

void encodeTupleUpdate(const Envelope& envelope, std::uint64_t ownerIncarnation, const Tuple& tuple,
                       std::string& out, TupleData data, std::size_t frameBytes) {
  // Sized once and written in place: this runs once per update sent.
  const auto bytes = frameBytes != 0 ? frameBytes : tupleUpdateFrameBytes(tuple);
  const auto start = out.size();
  out.resize(start + bytes - (data == TupleData::Omit ? tuple.data.size() : 0));
  RawWriter w(out.data() + start);
  w.u32(static_cast<std::uint32_t>(bytes - kFrameHeaderBytes));
  w.u8(static_cast<std::uint8_t>(MessageType::TupleUpdate));
  w.i32(envelope.source);
  w.i32(envelope.destination);
  w.u8(envelope.ttl);
  w.u64(ownerIncarnation);
  if (data == TupleData::Omit) {
    return writeTupleHead(w, tuple, static_cast<std::uint32_t>(tuple.data.size()));
  }
  writeTuple(w, tuple);
}

namespace {
// Where a TupleUpdate frame's key begins, after its length: type (1),
// envelope (9), incarnation (8), owner (4), creator (4), key length (2).
constexpr std::size_t kTupleUpdateKeyAt = 28;
}  // namespace

bool TupleUpdateEncoder::repeats(const Envelope& envelope, std::uint64_t ownerIncarnation,
                                 const Tuple& tuple) const {
  if (head_.empty() || envelope != envelope_ || ownerIncarnation != ownerIncarnation_ ||
      tuple.owner != owner_ || tuple.creator != creator_ || tuple.encoding != encoding_ ||
      tuple.key.size() != keyBytes_) {
    return false;
  }
  const std::string_view head(head_);
  // key | u8 mimetype length | mimetype | encoding
  return sameBytes(head.substr(kTupleUpdateKeyAt, keyBytes_), tuple.key) &&
         sameBytes(head.substr(kTupleUpdateKeyAt + keyBytes_ + 1,
                               head.size() - kTupleUpdateKeyAt - keyBytes_ - 2),
                   tuple.mimetype);
}

void TupleUpdateEncoder::append(const Envelope& envelope, std::uint64_t ownerIncarnation,
                                const Tuple& tuple, std::string& out) {
  const auto start = out.size();
  out.resize(start + tupleUpdateFrameBytes(tuple));
  write(envelope, ownerIncarnation, tuple, out.data() + start);
}

void TupleUpdateEncoder::write(const Envelope& envelope, std::uint64_t ownerIncarnation,
                               const Tuple& tuple, char* at) {
  const auto bytes = tupleUpdateFrameBytes(tuple);
  RawWriter w(at);
  w.u32(static_cast<std::uint32_t>(bytes - kFrameHeaderBytes));
  // Keys over 65535 or mimetypes over 255 bytes are cut by the field
  // writers; such a tuple is written field by field, as always.
  if (tuple.key.size() > 65535 || tuple.mimetype.size() > 255) {
    w.u8(static_cast<std::uint8_t>(MessageType::TupleUpdate));
    w.i32(envelope.source);
    w.i32(envelope.destination);
    w.u8(envelope.ttl);
    w.u64(ownerIncarnation);
    return writeTuple(w, tuple);
  }
  if (!repeats(envelope, ownerIncarnation, tuple)) {
    head_.assign(1, static_cast<char>(MessageType::TupleUpdate));
    Writer head(head_);
    writeEnvelope(head, envelope);
    head.u64(ownerIncarnation);
    head.i32(tuple.owner);
    head.i32(tuple.creator);
    head.str16(tuple.key);
    head.str8(tuple.mimetype);
    head.u8(static_cast<std::uint8_t>(tuple.encoding));
    envelope_ = envelope;
    ownerIncarnation_ = ownerIncarnation;
    owner_ = tuple.owner;
    creator_ = tuple.creator;
    encoding_ = tuple.encoding;
    keyBytes_ = tuple.key.size();
  }
  w.raw(head_);
  w.i64(micros(tuple.ts_write));
  w.i64(micros(tuple.ts_user));
  w.i64(micros(tuple.ts_expire));
  w.u64(tuple.seqno);
  w.u32(static_cast<std::uint32_t>(tuple.data.size()));
  w.raw(tuple.data);
}

std::string encodeFrame(const RoutedMessage& message) {
  std::string out;
  encode(message, out);
  return out;
}

void reEnvelope(std::string& frame, const Envelope& envelope) {
  std::string header;
  Writer w(header);
  writeEnvelope(w, envelope);
  frame.replace(kFrameHeaderBytes + 1, header.size(), header);
}

namespace {
// Sets `s` to the `n` bytes at `p`: within its capacity (the inbox's
// messages are reused, and keep their data's memory; a stream's data is
// mostly of the size held already) a plain copy, without string::assign's
// general case. A stream repeats its key and mimetype into
// a message that held them already: equal ones are compared, not copied.
inline void assignField(std::string& s, const char* p, std::size_t n) {
  if (n > s.capacity()) {
    s.assign(p, n);
    return;
  }
  if (s.size() != n) s.resize(n);
  copyField(s.data(), p, n);
}
inline bool sameField(const std::string& s, const char* p, std::size_t n) {
  return sameBytes(s, std::string_view(p, n));
}

// A well-formed TupleUpdate frame (after the type byte) read with one bounds
// check per variable-length part instead of one per field: false, with
// `out` partly written, for anything that is not (too short, an invalid id,
// a bad key, an unknown encoding, data over the limit or not ending the
// frame), which readRouted() then reads field by field for the reason.
bool readTupleUpdateFast(std::string_view in, std::size_t maxDataBytes, RoutedMessage& out) {
  // envelope (9), incarnation (8), owner (4), creator (4), key length (2).
  constexpr std::size_t kBeforeKey = 27;
  // encoding (1), three timestamps (24), seqno (8), data length (4).
  constexpr std::size_t kAfterMimetype = 37;
  const char* p = in.data();
  std::size_t left = in.size();
  if (left < kBeforeKey) return false;
  const auto source = static_cast<std::int32_t>(readBigEndian(p, 4));
  const auto destination = static_cast<std::int32_t>(readBigEndian(p + 4, 4));
  const auto owner = static_cast<std::int32_t>(readBigEndian(p + 17, 4));
  const auto creator = static_cast<std::int32_t>(readBigEndian(p + 21, 4));
  const auto keyBytes = static_cast<std::size_t>(readBigEndian(p + 25, 2));
  if (!isValidPeisId(source) || !isValidPeisId(destination) || !isValidPeisId(owner) ||
      !isValidPeisId(creator)) {
    return false;
  }
  left -= kBeforeKey;
  // The key, the mimetype's length byte, and at least the fixed fields.
  if (left < keyBytes + 1 + kAfterMimetype) return false;
  const char* key = p + kBeforeKey;
  const auto mimeBytes = static_cast<std::size_t>(static_cast<std::uint8_t>(key[keyBytes]));
  left -= keyBytes + 1;
  if (left < mimeBytes + kAfterMimetype) return false;
  const char* mime = key + keyBytes + 1;
  const char* fixed = mime + mimeBytes;
  const auto encoding = static_cast<std::uint8_t>(fixed[0]);
  const auto dataBytes = static_cast<std::size_t>(readBigEndian(fixed + 33, 4));
  left -= mimeBytes + kAfterMimetype;
  if (encoding > 1 || dataBytes != left || dataBytes > maxDataBytes) return false;
  // A stream repeats one key: the last key that passed is not checked again.
  thread_local std::string lastGoodKey;
  if (!sameField(lastGoodKey, key, keyBytes)) {
    if (keyProblem(std::string_view(key, keyBytes))) return false;
    lastGoodKey.assign(key, keyBytes);
  }
  out.envelope.source = source;
  out.envelope.destination = destination;
  out.envelope.ttl = static_cast<std::uint8_t>(p[8]);
  auto* update = std::get_if<TupleUpdate>(&out.body);
  if (!update) update = &out.body.emplace<TupleUpdate>();
  update->ownerIncarnation = readBigEndian(p + 9, 8);
  Tuple& t = update->tuple;
  t.owner = owner;
  t.creator = creator;
  if (!sameField(t.key, key, keyBytes)) t.key.assign(key, keyBytes);
  if (!sameField(t.mimetype, mime, mimeBytes)) t.mimetype.assign(mime, mimeBytes);
  t.encoding = static_cast<Encoding>(encoding);
  t.ts_write = fromMicros(static_cast<std::int64_t>(readBigEndian(fixed + 1, 8)));
  t.ts_user = fromMicros(static_cast<std::int64_t>(readBigEndian(fixed + 9, 8)));
  t.ts_expire = fromMicros(static_cast<std::int64_t>(readBigEndian(fixed + 17, 8)));
  t.seqno = readBigEndian(fixed + 25, 8);
  assignField(t.data, fixed + kAfterMimetype, dataBytes);
  return true;
}

// The envelope and body of a routed frame into `out`; a TupleUpdate (the
// hot path) is read straight into the message's tuple.
void readRouted(MessageType type, Reader& r, std::size_t maxDataBytes, RoutedMessage& out) {
  out.envelope.source = r.id("source");
  out.envelope.destination = r.id("destination");
  out.envelope.ttl = r.u8("ttl");
  if (type != MessageType::TupleUpdate) {
    out.body = decodeBody(type, r, maxDataBytes);
    return;
  }
  auto* update = std::get_if<TupleUpdate>(&out.body);
  if (!update) update = &out.body.emplace<TupleUpdate>();
  update->ownerIncarnation = r.u64("incarnation");
  readTupleInto(r, maxDataBytes, update->tuple);
}
}  // namespace

bool decodeRouted(std::string_view frame, std::size_t maxDataBytes, RoutedMessage& out,
                  std::string& error) {
  if (frame.empty()) {
    error = "empty frame";
    return false;
  }
  const auto rawType = static_cast<std::uint8_t>(frame[0]);
  if (!knownType(rawType) || !isRouted(static_cast<MessageType>(rawType))) {
    error = "unknown routed message type " + std::to_string(rawType);
    return false;
  }
  if (rawType == static_cast<std::uint8_t>(MessageType::TupleUpdate) &&
      readTupleUpdateFast(frame.substr(1), maxDataBytes, out)) {
    return true;
  }
  Reader r(frame.substr(1));
  readRouted(static_cast<MessageType>(rawType), r, maxDataBytes, out);
  r.end();
  if (!r.ok()) error = r.error();
  return r.ok();
}

bool decodeTupleUpdateHead(std::string_view head, std::size_t frameLength, std::size_t maxDataBytes,
                           RoutedMessage& out, std::size_t& dataAt) {
  if (head.empty() || head.size() >= frameLength ||
      static_cast<std::uint8_t>(head[0]) != static_cast<std::uint8_t>(MessageType::TupleUpdate)) {
    return false;
  }
  Reader r(head.substr(1));
  out.envelope.source = r.id("source");
  out.envelope.destination = r.id("destination");
  out.envelope.ttl = r.u8("ttl");
  auto* update = std::get_if<TupleUpdate>(&out.body);
  if (!update) update = &out.body.emplace<TupleUpdate>();
  update->ownerIncarnation = r.u64("incarnation");
  const std::size_t dataBytes = readTupleHead(r, update->tuple);
  // The data must end the frame exactly, within the limit: anything else
  // is read whole and rejected (or answered) as decode() does.
  dataAt = 1 + r.position();
  return r.ok() && dataBytes <= maxDataBytes && dataAt + dataBytes == frameLength;
}

bool isRoutedFrame(std::string_view frame) {
  return !frame.empty() && knownType(static_cast<std::uint8_t>(frame[0])) &&
         isRouted(static_cast<MessageType>(frame[0]));
}

DecodeResult decode(std::string_view frame, std::size_t maxDataBytes) {
  if (frame.empty()) return {std::nullopt, "empty frame"};
  const auto rawType = static_cast<std::uint8_t>(frame[0]);
  if (!knownType(rawType)) return {std::nullopt, "unknown message type " + std::to_string(rawType)};
  const auto type = static_cast<MessageType>(rawType);
  Reader r(frame.substr(1));
  Message message;
  if (isRouted(type)) {
    RoutedMessage routed;
    readRouted(type, r, maxDataBytes, routed);
    message = std::move(routed);
  } else {
    message = decodeLink(type, r);
  }
  r.end();
  if (!r.ok()) return {std::nullopt, r.error()};
  return {std::move(message), {}};
}

}  // namespace peis::wire

namespace peis::wire {

std::optional<Oversize> decodeOversize(std::string_view head, std::size_t maxDataBytes) {
  if (head.empty()) return std::nullopt;
  Oversize o;
  o.type = static_cast<MessageType>(head[0]);
  if (o.type != MessageType::TupleUpdate && o.type != MessageType::Write) return std::nullopt;
  Reader r(head.substr(1));
  o.envelope.source = r.id("source");
  o.envelope.destination = r.id("destination");
  o.envelope.ttl = r.u8("ttl");
  if (o.type == MessageType::Write) {
    o.request = r.u64("request");
    const auto op = r.u8("op");
    const auto hasIf = r.u8("if-seqno flag");
    r.u64("if-seqno");
    const auto ttl = r.i64("ttl");
    r.u32("wait");
    if (r.ok() && (op > 2 || hasIf > 1 || ttl < 0)) return std::nullopt;
  } else {
    o.ownerIncarnation = r.u64("incarnation");
  }
  o.dataBytes = readTupleHead(r, o.tuple);
  if (!r.ok() || o.dataBytes <= maxDataBytes) return std::nullopt;
  return o;
}

RoutedMessage answerOversize(const Oversize& o, PeisId self, std::size_t maxDataBytes) {
  const auto limit = static_cast<std::uint32_t>(std::min<std::size_t>(maxDataBytes, kMaxDataBytes));
  const bool forMe = o.envelope.destination == self;
  if (o.type == MessageType::Write) {
    WriteResult result;
    result.request = o.request;
    result.status = static_cast<std::uint8_t>(static_cast<int>(ErrorCode::TooLarge) + 1);
    result.message = "data is " + std::to_string(o.dataBytes) + " bytes; " +
                     (forMe ? std::string("this PEIS")
                            : "PEIS " + std::to_string(self) + " on the route to PEIS " +
                                  std::to_string(o.envelope.destination)) +
                     " accepts at most " + std::to_string(limit) + " (see --peis-max-data)";
    return RoutedMessage{Envelope{self, o.envelope.source, kDefaultTtl}, std::move(result)};
  }
  TupleWithheld withheld{o.ownerIncarnation, self, limit, o.dataBytes, o.tuple};
  // For this PEIS the notice stands in for the owner's update; on the way, it
  // goes on from here.
  const Envelope envelope = forMe ? Envelope{o.envelope.source, self, kDefaultTtl}
                                  : Envelope{self, o.envelope.destination, kDefaultTtl};
  return RoutedMessage{envelope, std::move(withheld)};
}

}  // namespace peis::wire
