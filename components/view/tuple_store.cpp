// The view's store of tuples, versions and histories (tuple_store.h).
#include "view/tuple_store.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "view/json.h"

namespace peis::view {

bool isMetaInputKey(std::string_view key) { return key.substr(0, 3) == "mi-"; }

Preview makePreview(const std::string& data, Encoding encoding, std::size_t maxBytes) {
  Preview preview;
  preview.truncated = data.size() > maxBytes;
  if (encoding == Encoding::Binary) {
    preview.binary = true;
    return preview;
  }
  std::size_t length = std::min(data.size(), maxBytes);
  // Cut at a character: a cut before a continuation byte moves back to the
  // start of that character (at most three bytes; invalid data stays invalid).
  if (preview.truncated) {
    for (int step = 0;
         step < 3 && length > 0 && (static_cast<unsigned char>(data[length]) & 0xC0) == 0x80;
         ++step)
      --length;
  }
  const std::string_view text(data.data(), length);
  for (unsigned char c : text) {
    if ((c < 0x20 && c != '\t' && c != '\n' && c != '\r') || c == 0x7F) {
      preview.binary = true;
      return preview;
    }
  }
  if (!json::isValidUtf8(text)) {
    preview.binary = true;
    return preview;
  }
  preview.text.assign(text);
  return preview;
}

std::optional<double> parseNumber(std::string_view data) {
  std::string text(data);
  const char* begin = text.c_str();
  while (*begin == ' ' || *begin == '\t' || *begin == '\n' || *begin == '\r') ++begin;
  if (*begin == '\0') return std::nullopt;
  // strtod also reads hex, "inf" and "nan": only decimal numbers count.
  for (const char* p = begin; *p; ++p) {
    const char c = *p;
    if (!((c >= '0' && c <= '9') || c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E' ||
          c == ' ' || c == '\t' || c == '\n' || c == '\r'))
      return std::nullopt;
  }
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(begin, &end);
  if (end == begin || errno == ERANGE || !std::isfinite(value)) return std::nullopt;
  while (*end == ' ' || *end == '\t' || *end == '\n' || *end == '\r') ++end;
  if (*end != '\0') return std::nullopt;
  return value;
}

void TupleStore::touch(Entry& entry, const TupleRef& ref) {
  if (entry.tuple.version != 0) byVersion_.erase(entry.tuple.version);
  entry.tuple.version = ++version_;
  byVersion_.emplace(entry.tuple.version, ref);
}

void TupleStore::log(const StoredTuple& tuple) {
  if (!matchesAny(logFilters_, tuple.owner, tuple.key, tuple.creator, tuple.mimetype)) return;
  log_.push_back(LogEntry{++logSeq_, tuple});
  while (log_.size() > limits_.logEntries) log_.pop_front();
}

void TupleStore::change(const Tuple& tuple, Timestamp arrival) {
  TupleRef ref{tuple.owner, tuple.key};
  Entry& entry = entries_[ref];
  StoredTuple& t = entry.tuple;
  t.owner = tuple.owner;
  t.key = tuple.key;
  t.creator = tuple.creator;
  t.mimetype = tuple.mimetype;
  t.encoding = tuple.encoding;
  t.tsWrite = tuple.ts_write;
  t.tsUser = tuple.ts_user;
  t.tsExpire = tuple.ts_expire;
  t.seqno = tuple.seqno;
  t.size = tuple.data.size();
  Preview preview = makePreview(tuple.data, tuple.encoding, limits_.previewBytes);
  t.preview = std::move(preview.text);
  t.binary = preview.binary;
  t.truncated = preview.truncated;
  t.number = !t.binary && tuple.data.size() <= limits_.numberBytes ? parseNumber(tuple.data)
                                                                   : std::nullopt;
  t.deleted = false;
  t.arrival = arrival;
  entry.rate.add(arrival);
  if (t.number) {
    if (!entry.history) entry.history = std::make_unique<std::deque<Sample>>();
    entry.history->push_back(
        Sample{tuple.ts_write != kNoTime ? tuple.ts_write : arrival, *t.number});
    while (entry.history->size() > limits_.historySamples) entry.history->pop_front();
    ++entry.samplesTaken;
  }
  touch(entry, ref);
  if (isMetaInputKey(t.key)) metaInputs_.insert(ref);
  log(t);
}

void TupleStore::remove(const Tuple& tuple, Timestamp arrival) {
  TupleRef ref{tuple.owner, tuple.key};
  auto it = entries_.find(ref);
  if (it == entries_.end()) return;  // never shown: nothing to take back
  StoredTuple& t = it->second.tuple;
  t.deleted = true;
  t.seqno = std::max(t.seqno, tuple.seqno);
  t.arrival = arrival;
  touch(it->second, ref);
  metaInputs_.erase(ref);
  log(t);
}

void TupleStore::purgeTombstones(Timestamp now) {
  for (auto it = entries_.begin(); it != entries_.end();) {
    const StoredTuple& t = it->second.tuple;
    if (t.deleted && now - t.arrival >= limits_.tombstoneLife) {
      purgedUpTo_ = std::max(purgedUpTo_, t.version);
      byVersion_.erase(t.version);
      it = entries_.erase(it);
    } else {
      ++it;
    }
  }
}

TupleStore::Changes TupleStore::changesSince(std::uint64_t cursor,
                                             const std::vector<Filter>& filters,
                                             std::size_t maxRows) const {
  Changes changes;
  changes.reset = cursor == 0 || cursor < purgedUpTo_;
  if (changes.reset) cursor = 0;
  changes.cursor = cursor;
  for (auto it = byVersion_.upper_bound(cursor); it != byVersion_.end(); ++it) {
    const StoredTuple& t = entries_.at(it->second).tuple;
    if (changes.reset && t.deleted) {
      changes.cursor = it->first;
      continue;
    }
    if (!matchesAny(filters, t.owner, t.key, t.creator, t.mimetype)) {
      changes.cursor = it->first;
      continue;
    }
    if (changes.rows.size() >= maxRows) {
      changes.more = true;
      break;
    }
    changes.rows.push_back(t);
    changes.cursor = it->first;
  }
  return changes;
}

const StoredTuple* TupleStore::find(PeisId owner, const std::string& key) const {
  auto it = entries_.find(TupleRef{owner, key});
  return it == entries_.end() ? nullptr : &it->second.tuple;
}

double TupleStore::rate(PeisId owner, const std::string& key, Timestamp now) const {
  auto it = entries_.find(TupleRef{owner, key});
  return it == entries_.end() ? 0.0 : it->second.rate.rate(now);
}

TupleStore::HistoryChunk TupleStore::historySince(PeisId owner, const std::string& key,
                                                  std::uint64_t seen) const {
  HistoryChunk chunk;
  auto it = entries_.find(TupleRef{owner, key});
  if (it == entries_.end() || !it->second.history) {
    chunk.reset = seen != 0;
    return chunk;
  }
  const auto& history = *it->second.history;
  const std::uint64_t taken = it->second.samplesTaken;
  const std::uint64_t firstKept = taken - history.size();
  chunk.seen = taken;
  chunk.reset = seen == 0 || seen < firstKept || seen > taken;
  const std::uint64_t from = chunk.reset ? firstKept : seen;
  for (std::uint64_t i = from; i < taken; ++i) chunk.samples.push_back(history[i - firstKept]);
  return chunk;
}

TupleStore::LogChunk TupleStore::logSince(std::uint64_t after, std::size_t max) const {
  LogChunk chunk;
  chunk.last = after;
  if (log_.empty()) return chunk;
  chunk.reset = after + 1 < log_.front().seq;
  for (const auto& entry : log_) {
    if (entry.seq <= after) continue;
    if (chunk.entries.size() >= max) break;
    chunk.entries.push_back(entry);
    chunk.last = entry.seq;
  }
  return chunk;
}

std::vector<StoredTuple> TupleStore::metaInputs() const {
  std::vector<StoredTuple> result;
  for (const auto& ref : metaInputs_) result.push_back(entries_.at(ref).tuple);
  return result;
}

}  // namespace peis::view
