// RecordingWriter: appends tuple events to a recording file on a thread of
// its own, so whoever calls add() (the kernel thread) never waits on the
// disk. Events are committed in batches, one transaction each, at most
// `commitInterval` after the oldest of them arrived (or at once when
// `batchEvents` wait). With WAL, a process killed at any moment leaves a
// file that opens intact with every batch committed before; what was still
// queued is lost. When more than `maxQueuedBytes` wait (a disk that cannot
// keep up), new events are dropped and counted (recording.dropped).
#pragma once

#include <peis/tuple.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

namespace peis::recorder {

struct RecordedEvent {
  Timestamp received;  // when the recorder got it (its wall clock)
  bool deleted = false;
  Tuple tuple;
};

struct WriterSettings {
  std::chrono::milliseconds commitInterval{200};
  std::size_t batchEvents = 50000;
  std::size_t maxQueuedBytes = std::size_t{512} << 20;
};

// When the writer thread commits: something waits, and either enough waits
// or the oldest has waited a commit interval (or the writer is stopping). Pure.
bool shouldCommit(std::size_t waiting, std::chrono::steady_clock::time_point oldestArrival,
                  std::chrono::steady_clock::time_point now, const WriterSettings& settings,
                  bool stopping);

struct WriterStats {
  std::uint64_t written = 0;  // events committed
  std::uint64_t dropped = 0;  // events dropped because too many waited
  std::uint64_t commits = 0;
  std::chrono::microseconds longestCommit{0};
};

class RecordingWriter {
 public:
  using OwnerName = std::function<std::string(PeisId owner)>;
  using Failure = std::function<void(const std::string& why)>;

  // Creates the recording at `path` (which must not exist) with the values
  // of `header` in its recording table, and starts the writer thread.
  // Throws Error(InvalidConfig) if the file cannot be made. `ownerName` is
  // asked (on the writer thread) for the name of each owner seen first;
  // `onFailure` is called once if a write fails later (disk full, ...).
  RecordingWriter(const std::string& path, const std::map<std::string, std::string>& header,
                  WriterSettings settings, OwnerName ownerName, Failure onFailure);
  // finish() if not done.
  ~RecordingWriter();
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  // Queues one event. Any thread; takes a lock for a push, never waits on the disk.
  void add(RecordedEvent event);
  // Commits everything queued, writes `footer` into the recording table,
  // checkpoints the WAL into the file and closes it. Blocks.
  void finish(const std::map<std::string, std::string>& footer);
  WriterStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::recorder
