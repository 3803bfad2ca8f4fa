// RemoteQuota: the keys and bytes remote writers hold; see remote_quota.h.
#include "remote_quota.h"

namespace peis {

namespace {

std::string bytesText(std::size_t bytes) { return std::to_string(bytes) + " bytes"; }

}  // namespace

std::optional<std::string> RemoteQuota::check(const std::string& writer, std::string_view key,
                                              std::size_t bytes,
                                              std::string_view writerText) const {
  const auto it = byKey_.find(key);
  const bool heldByWriter = it != byKey_.end() && it->second.writer == writer;
  const bool heldByAnother = it != byKey_.end() && !heldByWriter;
  const auto mine = heldBy(writer);
  // What the write adds for this writer, and for all remote writers.
  const std::size_t newKeys = heldByWriter ? 0 : 1;
  const std::size_t freedByWriter = heldByWriter ? it->second.bytes : 0;
  const std::size_t freedInTotal = it != byKey_.end() ? it->second.bytes : 0;
  const std::size_t newTotalKeys = (heldByWriter || heldByAnother) ? 0 : 1;
  const std::string who(writerText);
  if (mine.keys + newKeys > limits_.keys) {
    return who + " holds " + std::to_string(mine.keys) + " keys here: its quota is " +
           std::to_string(limits_.keys) + " (--peis-quota-keys)";
  }
  if (mine.bytes - freedByWriter + bytes > limits_.bytes) {
    return who + " would hold " + bytesText(mine.bytes - freedByWriter + bytes) +
           " here: its quota is " + bytesText(limits_.bytes) + " (--peis-quota-bytes)";
  }
  if (total_.keys + newTotalKeys > limits_.totalKeys) {
    return "remote writers hold " + std::to_string(total_.keys) + " keys here: the quota is " +
           std::to_string(limits_.totalKeys) + " (--peis-quota-total-keys)";
  }
  if (total_.bytes - freedInTotal + bytes > limits_.totalBytes) {
    return "remote writers would hold " + bytesText(total_.bytes - freedInTotal + bytes) +
           " here: the quota is " + bytesText(limits_.totalBytes) + " (--peis-quota-total-bytes)";
  }
  return std::nullopt;
}

void RemoteQuota::release(std::map<std::string, Holding, std::less<>>::iterator it) {
  auto& held = byWriter_[it->second.writer];
  held.keys -= 1;
  held.bytes -= it->second.bytes;
  if (held.keys == 0) byWriter_.erase(it->second.writer);
  total_.keys -= 1;
  total_.bytes -= it->second.bytes;
  byKey_.erase(it);
}

void RemoteQuota::onChanged(std::string_view key, const std::string& writer, std::size_t bytes) {
  if (auto it = byKey_.find(key); it != byKey_.end()) release(it);
  if (writer.empty()) return;
  byKey_.emplace(std::string(key), Holding{writer, bytes});
  auto& held = byWriter_[writer];
  held.keys += 1;
  held.bytes += bytes;
  total_.keys += 1;
  total_.bytes += bytes;
}

void RemoteQuota::onDeleted(std::string_view key) {
  if (auto it = byKey_.find(key); it != byKey_.end()) release(it);
}

RemoteQuota::Held RemoteQuota::heldBy(const std::string& writer) const {
  const auto it = byWriter_.find(writer);
  return it == byWriter_.end() ? Held{} : it->second;
}

}  // namespace peis
