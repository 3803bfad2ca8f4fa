// RemoteQuota: what remote writers hold in this PEIS — the own tuples whose
// current value a remote writer wrote, counted per writer and for all of
// them together — and whether a write keeps within Options::limits
// (quotaKeys, quotaBytes, quotaTotalKeys, quotaTotalBytes). A writer is
// whatever the owner can tell writers apart by: its PEIS id in an open
// ecology, its principal in a secured one (docs/security.md, "Limits").
// Pure bookkeeping; the OwnerGuard asks it and keeps it current.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace peis {

class RemoteQuota {
 public:
  struct Limits {
    std::size_t keys = 1024, bytes = 64u << 20, totalKeys = 8192, totalBytes = 256u << 20;
  };
  explicit RemoteQuota(Limits limits) : limits_(limits) {}

  // Why `writer` may not make `key` hold `bytes` data bytes (nullopt: it
  // may). `writerText` names the writer in the message.
  std::optional<std::string> check(const std::string& writer, std::string_view key,
                                   std::size_t bytes, std::string_view writerText) const;
  // An own tuple now holds `bytes` written by `writer` (empty: this PEIS
  // itself, which holds no quota).
  void onChanged(std::string_view key, const std::string& writer, std::size_t bytes);
  void onDeleted(std::string_view key);
  // Nothing held by any remote writer (the common case: changes by this
  // PEIS need no look-up then).
  bool empty() const { return byKey_.empty(); }

  struct Held {
    std::size_t keys = 0, bytes = 0;
  };
  Held heldBy(const std::string& writer) const;
  Held total() const { return total_; }

 private:
  struct Holding {
    std::string writer;
    std::size_t bytes = 0;
  };
  void release(std::map<std::string, Holding, std::less<>>::iterator it);

  Limits limits_;
  std::map<std::string, Holding, std::less<>> byKey_;
  std::map<std::string, Held> byWriter_;
  Held total_;
};

}  // namespace peis
