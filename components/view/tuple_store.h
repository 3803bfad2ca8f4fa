// What the view knows of the ecology's tuples, and the heart of its
// coalescing. Every change the view's kernel accepts is applied here (on the
// kernel thread, under the caller's lock): the entry keeps the tuple's meta
// data and a short preview of its data (not the data itself: an image stays
// in the kernel's cache and is read from there when a page asks for it),
// gets the next store version, and moves to the end of the version index.
// A page's cursor is the last version it was sent, so "what changed since"
// is one walk of the index from the cursor, and however often a tuple
// changed between two walks it comes out once, with its latest value: that
// is the coalescing per tuple (docs/operating.md). Deleted tuples stay as
// tombstones for a while so pages learn of the deletion; a cursor older
// than a purged tombstone starts the page over.
//
// Numeric values keep a bounded history (for the plot); changes of tuples
// that match the meta-level filters are also kept in a bounded log (so no
// event is lost to coalescing). Pure: no kernel, no clock, no lock.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "peis/tuple.h"
#include "view/filter.h"
#include "view/rate_meter.h"

namespace peis::view {

// One tuple as the view shows it.
struct StoredTuple {
  PeisId owner = 0;
  std::string key;
  PeisId creator = 0;
  std::string mimetype;
  Encoding encoding = Encoding::Ascii;
  Timestamp tsWrite{}, tsUser{}, tsExpire{};
  std::uint64_t seqno = 0;
  std::size_t size = 0;          // bytes of data
  std::string preview;           // the data's first bytes (cut at a character), when text
  bool binary = false;           // not text: Binary encoding, or control bytes / invalid UTF-8
  bool truncated = false;        // the preview is not the whole data
  std::optional<double> number;  // the value, when the whole data is one number
  bool deleted = false;          // a tombstone
  Timestamp arrival{};           // when the view got it (or the deletion)
  std::uint64_t version = 0;

  std::string id() const { return std::to_string(owner) + "." + key; }
};

struct Sample {
  Timestamp time;  // the owner's ts_write (the arrival when not set)
  double value;
};

struct StoreLimits {
  std::size_t previewBytes = 512;
  std::size_t historySamples = 600;
  std::size_t logEntries = 500;
  std::chrono::seconds tombstoneLife{30};
  std::size_t numberBytes = 64;  // longer data is never taken as a number
};

class TupleStore {
 public:
  explicit TupleStore(StoreLimits limits = {}) : limits_(limits) {}

  // The meta-level's filters: changes of matching tuples are also logged.
  void setLogFilters(std::vector<Filter> filters) { logFilters_ = std::move(filters); }
  const std::vector<Filter>& logFilters() const { return logFilters_; }

  void change(const Tuple& tuple, Timestamp arrival);
  void remove(const Tuple& tuple, Timestamp arrival);
  // Forgets tombstones older than the limit at `now`.
  void purgeTombstones(Timestamp now);

  // The version of the last change (0: none yet).
  std::uint64_t version() const { return version_; }
  std::size_t size() const { return entries_.size(); }

  // What changed after `cursor` among the tuples matching any of `filters`.
  // cursor 0, or a cursor older than a purged tombstone, gives every live
  // matching tuple and `reset`. At most `maxRows` rows; then `more` is set
  // and `cursor` is where the next call goes on.
  struct Changes {
    std::vector<StoredTuple> rows;  // changed or deleted (tombstones), in version order
    std::uint64_t cursor = 0;
    bool reset = false;
    bool more = false;
  };
  Changes changesSince(std::uint64_t cursor, const std::vector<Filter>& filters,
                       std::size_t maxRows) const;

  const StoredTuple* find(PeisId owner, const std::string& key) const;
  double rate(PeisId owner, const std::string& key, Timestamp now) const;

  // The numeric samples of a tuple from the `seen`-th on (counting every
  // sample the store ever took of it); `reset` when some of those are no
  // longer kept (or `seen` is 0), and then all kept samples come.
  struct HistoryChunk {
    std::vector<Sample> samples;
    std::uint64_t seen = 0;  // pass this next time
    bool reset = false;
  };
  HistoryChunk historySince(PeisId owner, const std::string& key, std::uint64_t seen) const;

  // The log of changes of tuples matching the log filters.
  struct LogEntry {
    std::uint64_t seq = 0;  // from 1
    StoredTuple tuple;
  };
  // Entries with seq > `after`, at most `max`; `reset` when entries after
  // `after` were already dropped from the bounded log.
  struct LogChunk {
    std::vector<LogEntry> entries;
    std::uint64_t last = 0;
    bool reset = false;
  };
  LogChunk logSince(std::uint64_t after, std::size_t max) const;

  // Every live tuple whose first key part starts with "mi-" (the meta
  // tuples of the configuration), ordered by owner and key.
  std::vector<StoredTuple> metaInputs() const;

 private:
  struct Entry {
    StoredTuple tuple;
    RateMeter rate;
    std::unique_ptr<std::deque<Sample>> history;
    std::uint64_t samplesTaken = 0;
  };

  void touch(Entry& entry, const TupleRef& ref);
  void log(const StoredTuple& tuple);

  StoreLimits limits_;
  std::vector<Filter> logFilters_;
  std::map<TupleRef, Entry> entries_;
  std::map<std::uint64_t, TupleRef> byVersion_;
  std::set<TupleRef> metaInputs_;
  std::uint64_t version_ = 0;
  std::uint64_t purgedUpTo_ = 0;  // newest version of a purged tombstone
  std::deque<LogEntry> log_;
  std::uint64_t logSeq_ = 0;
};

// True for a key whose first part starts with "mi-".
bool isMetaInputKey(std::string_view key);

// The preview and kind of `data` (pure, for the store and its tests).
struct Preview {
  std::string text;
  bool binary = false;
  bool truncated = false;
};
Preview makePreview(const std::string& data, Encoding encoding, std::size_t maxBytes);
// The number `data` holds when it is one finite decimal number (white space
// around allowed), else nothing.
std::optional<double> parseNumber(std::string_view data);

}  // namespace peis::view
