// Big-endian byte strings for the security layer's formats (certificates,
// identities, the handshake's messages): a writer that appends fields and
// a reader that checks every length and never reads past its input. The
// layouts are stated in docs/protocol.md §15.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace peis::security {

class ByteWriter {
 public:
  void u8(std::uint64_t v) { put(v, 1); }
  void u16(std::uint64_t v) { put(v, 2); }
  void u32(std::uint64_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void raw(std::string_view bytes) { out_.append(bytes); }
  // u8 length, then the bytes (at most 255).
  void str8(std::string_view s) {
    const auto n = s.size() > 255 ? 255 : s.size();
    u8(n);
    out_.append(s.substr(0, n));
  }
  // u16 length, then the bytes (at most 65535).
  void str16(std::string_view s) {
    const auto n = s.size() > 65535 ? 65535 : s.size();
    u16(n);
    out_.append(s.substr(0, n));
  }
  std::string& bytes() { return out_; }
  std::string take() { return std::move(out_); }

 private:
  void put(std::uint64_t v, int n) {
    for (int i = n - 1; i >= 0; --i) out_.push_back(static_cast<char>(v >> (8 * i)));
  }
  std::string out_;
};

class ByteReader {
 public:
  explicit ByteReader(std::string_view in) : in_(in) {}
  std::uint64_t u8() { return get(1); }
  std::uint64_t u16() { return get(2); }
  std::uint64_t u32() { return get(4); }
  std::uint64_t u64() { return get(8); }
  std::string_view raw(std::size_t n) {
    if (!ok_ || in_.size() - pos_ < n) {
      ok_ = false;
      return {};
    }
    const auto s = in_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  std::string str8() { return std::string(raw(u8())); }
  std::string str16() { return std::string(raw(u16())); }
  // Every read so far was within the input.
  bool ok() const { return ok_; }
  bool atEnd() const { return pos_ == in_.size(); }
  std::size_t position() const { return pos_; }

 private:
  std::uint64_t get(int n) {
    if (!ok_ || in_.size() - pos_ < static_cast<std::size_t>(n)) {
      ok_ = false;
      return 0;
    }
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v = (v << 8) | static_cast<std::uint8_t>(in_[pos_++]);
    return v;
  }
  std::string_view in_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace peis::security
