// Reading a recording: a summary of what it holds (for peis-inspect) and
// its events in the order they arrived (for peis-replay). Opening checks
// the file (checkRecording), so a file that is not a recording is a clear
// error before anything is read.
#pragma once

#include <peis/tuple.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "recorder/sqlite_db.h"

namespace peis::recorder {

struct TupleSummary {
  PeisId owner = 0;
  std::string key;
  std::int64_t changes = 0, deletions = 0;
  std::int64_t bytes = 0;  // data of the changes
  Timestamp first, last;   // received
};

struct RecordingSummary {
  std::map<std::string, std::string> values;  // the recording table
  std::map<PeisId, std::string> owners;       // id -> name
  std::int64_t changes = 0, deletions = 0, bytes = 0;
  Timestamp first, last;                    // received, of the first and last event
  std::optional<Timestamp> started, ended;  // ended only after a clean stop
  std::vector<TupleSummary> tuples;         // by owner, then key
  std::int64_t events() const { return changes + deletions; }
};

// One stored event: the tuple as the recorder received it.
struct StoredEvent {
  std::int64_t id = 0;
  Timestamp received;
  bool deleted = false;
  Tuple tuple;
};

class RecordingReader {
 public:
  // Opens `path` read-only and checks it; Error(InvalidConfig) otherwise.
  explicit RecordingReader(const std::string& path);
  ~RecordingReader();

  RecordingSummary summary();
  // The owners of recorded tuples, with their names; with `beyondKernel`
  // only those with a tuple outside kernel.* (what a stand-in replays).
  std::map<PeisId, std::string> owners(bool beyondKernel = false);
  // Starts (again) at the first event.
  void rewind();
  // The next event in the order of arrival; false after the last.
  bool next(StoredEvent& event);

 private:
  std::unique_ptr<Database> db_;
  std::unique_ptr<Statement> events_;
};

// "2026-11-24 17:05:01.123" (UTC).
std::string formatTime(Timestamp t);

}  // namespace peis::recorder
