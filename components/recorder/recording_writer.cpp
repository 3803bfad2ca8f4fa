// Writing a recording on a thread of its own (see recording_writer.h).
#include "recorder/recording_writer.h"

#include <peis/error.h>

#include <condition_variable>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "recorder/recording_format.h"
#include "recorder/sqlite_db.h"

namespace peis::recorder {

using SteadyClock = std::chrono::steady_clock;

bool shouldCommit(std::size_t waiting, SteadyClock::time_point oldestArrival,
                  SteadyClock::time_point now, const WriterSettings& settings, bool stopping) {
  if (waiting == 0) return false;
  return stopping || waiting >= settings.batchEvents ||
         now - oldestArrival >= settings.commitInterval;
}

namespace {

std::int64_t micros(Timestamp t) { return t.time_since_epoch().count(); }

std::size_t sizeOf(const RecordedEvent& e) {
  return sizeof(RecordedEvent) + e.tuple.key.size() + e.tuple.data.size() + e.tuple.mimetype.size();
}

struct PairHash {
  std::size_t operator()(const std::pair<PeisId, std::string>& p) const {
    return std::hash<std::string>()(p.second) * 31 + static_cast<std::size_t>(p.first);
  }
};

}  // namespace

struct RecordingWriter::Impl {
  WriterSettings settings;
  OwnerName ownerName;
  Failure onFailure;
  Database db;
  Statement insertEvent, insertTuple, insertOwner, setValue;
  std::unordered_map<std::pair<PeisId, std::string>, std::int64_t, PairHash> tupleIds;
  std::unordered_set<PeisId> owners;
  std::uint64_t droppedWritten = 0;  // the value of `dropped` in the file

  mutable std::mutex mu;
  std::condition_variable wake;
  std::vector<RecordedEvent> queue;  // guarded by mu
  std::size_t queuedBytes = 0;       // guarded by mu
  SteadyClock::time_point oldest;    // guarded by mu: arrival of queue.front()
  bool stopping = false;             // guarded by mu
  bool failed = false;               // guarded by mu
  WriterStats stats;                 // guarded by mu
  std::thread thread;
  bool finished = false;

  // Checkpoints (the WAL's pages copied into the database, with fsync) run
  // on a thread and connection of their own, so a commit is only a write
  // into the WAL and never waits for them.
  std::string path;
  std::mutex checkpointMu;
  std::condition_variable checkpointWake;
  bool checkpointStop = false;  // guarded by checkpointMu
  std::thread checkpointer;

  void checkpointLoop() {
    try {
      Database own(path, Database::Mode::ReadWrite);
      std::unique_lock lock(checkpointMu);
      while (!checkpointWake.wait_for(lock, kCheckpointPeriod, [&] { return checkpointStop; })) {
        lock.unlock();
        own.exec("PRAGMA wal_checkpoint(PASSIVE)");
        lock.lock();
      }
    } catch (const Error&) {
      // The final checkpoint at finish() folds the WAL in anyway.
    }
  }

  static constexpr std::chrono::seconds kCheckpointPeriod{1};

  Impl(const std::string& file, WriterSettings s)
      : settings(s),
        db(file, Database::Mode::Create),
        insertEvent(prepareAfterSchema(db)),
        insertTuple(db.prepare("INSERT INTO tuples (owner, key) VALUES (?1, ?2)")),
        insertOwner(db.prepare("INSERT OR IGNORE INTO owners (id, name) VALUES (?1, ?2)")),
        setValue(db.prepare("INSERT OR REPLACE INTO recording (name, value) VALUES (?1, ?2)")),
        path(file) {
    db.exec("PRAGMA wal_autocheckpoint = 0");
  }

  static Statement prepareAfterSchema(Database& db) {
    createSchema(db);
    return db.prepare(
        "INSERT INTO events (received, tuple, deleted, creator, seqno, ts_write, ts_user, "
        "ts_expire, mimetype, encoding, data) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, "
        "?11)");
  }

  void put(const std::string& name, const std::string& value) {
    setValue.bindText(1, name).bindText(2, value).run();
  }

  std::int64_t tupleId(PeisId owner, const std::string& key) {
    auto [it, added] = tupleIds.try_emplace({owner, key}, 0);
    if (!added) return it->second;
    if (owners.insert(owner).second)
      insertOwner.bind(1, owner).bindText(2, ownerName ? ownerName(owner) : "").run();
    insertTuple.bind(1, owner).bindText(2, key).run();
    it->second = sqlite3_last_insert_rowid(db.handle());
    return it->second;
  }

  void write(const std::vector<RecordedEvent>& batch, std::uint64_t dropped) {
    const auto began = SteadyClock::now();
    db.exec("BEGIN");
    for (const auto& e : batch) {
      const Tuple& t = e.tuple;
      insertEvent.bind(1, micros(e.received))
          .bind(2, tupleId(t.owner, t.key))
          .bind(3, e.deleted ? 1 : 0)
          .bind(4, t.creator)
          .bind(5, static_cast<std::int64_t>(t.seqno))
          .bind(6, micros(t.ts_write))
          .bind(7, micros(t.ts_user))
          .bind(8, micros(t.ts_expire))
          .bindText(9, t.mimetype)
          .bind(10, t.encoding == Encoding::Binary ? 1 : 0)
          .bindBlob(11, t.data)
          .run();
    }
    if (dropped != droppedWritten) {
      put("dropped", std::to_string(dropped));
      droppedWritten = dropped;
    }
    db.exec("COMMIT");
    const auto took =
        std::chrono::duration_cast<std::chrono::microseconds>(SteadyClock::now() - began);
    std::lock_guard lock(mu);
    stats.written += batch.size();
    ++stats.commits;
    stats.longestCommit = std::max(stats.longestCommit, took);
  }

  void loop() {
    std::vector<RecordedEvent> batch;
    for (;;) {
      std::uint64_t dropped = 0;
      {
        std::unique_lock lock(mu);
        for (;;) {
          const auto now = SteadyClock::now();
          if (shouldCommit(queue.size(), oldest, now, settings, stopping)) break;
          if (stopping) return;  // and nothing waits
          if (queue.empty())
            wake.wait(lock);
          else
            wake.wait_until(lock, oldest + settings.commitInterval);
        }
        batch.swap(queue);
        queuedBytes = 0;
        dropped = stats.dropped;
      }
      try {
        write(batch, dropped);
      } catch (const Error& e) {
        {
          std::lock_guard lock(mu);
          failed = true;
          stats.dropped += batch.size();
        }
        try {
          db.exec("ROLLBACK");
        } catch (const Error&) {
        }
        if (onFailure) onFailure(e.what());
        return;
      }
      batch.clear();
    }
  }
};

RecordingWriter::RecordingWriter(const std::string& path,
                                 const std::map<std::string, std::string>& header,
                                 WriterSettings settings, OwnerName ownerName, Failure onFailure)
    : impl_(std::make_unique<Impl>(path, settings)) {
  impl_->ownerName = std::move(ownerName);
  impl_->onFailure = std::move(onFailure);
  impl_->db.exec("BEGIN");
  impl_->put("format", kFormatName);
  impl_->put("version", std::to_string(kFormatVersion));
  impl_->put("commit_interval_ms", std::to_string(settings.commitInterval.count()));
  impl_->put("dropped", "0");
  for (const auto& [name, value] : header) impl_->put(name, value);
  impl_->db.exec("COMMIT");
  impl_->thread = std::thread([this] { impl_->loop(); });
  impl_->checkpointer = std::thread([this] { impl_->checkpointLoop(); });
}

RecordingWriter::~RecordingWriter() {
  if (!impl_->finished) {
    try {
      finish({});
    } catch (const Error&) {
      // The file stays as the last commit left it.
    }
  }
}

void RecordingWriter::add(RecordedEvent event) {
  const std::size_t bytes = sizeOf(event);
  bool first = false;
  {
    std::lock_guard lock(impl_->mu);
    if (impl_->failed || impl_->stopping ||
        impl_->queuedBytes + bytes > impl_->settings.maxQueuedBytes) {
      ++impl_->stats.dropped;
      return;
    }
    first = impl_->queue.empty();
    if (first) impl_->oldest = SteadyClock::now();
    impl_->queue.push_back(std::move(event));
    impl_->queuedBytes += bytes;
    if (!first && impl_->queue.size() != impl_->settings.batchEvents) return;
  }
  impl_->wake.notify_one();
}

void RecordingWriter::finish(const std::map<std::string, std::string>& footer) {
  if (impl_->finished) return;
  impl_->finished = true;
  {
    std::lock_guard lock(impl_->mu);
    impl_->stopping = true;
  }
  impl_->wake.notify_one();
  impl_->thread.join();
  {
    std::lock_guard lock(impl_->checkpointMu);
    impl_->checkpointStop = true;
  }
  impl_->checkpointWake.notify_one();
  impl_->checkpointer.join();
  impl_->db.exec("BEGIN");
  impl_->put("dropped", std::to_string(stats().dropped));
  for (const auto& [name, value] : footer) impl_->put(name, value);
  impl_->db.exec("COMMIT");
  // One file again: the WAL's pages go into the database and the WAL is emptied.
  impl_->db.exec("PRAGMA wal_checkpoint(TRUNCATE)");
}

WriterStats RecordingWriter::stats() const {
  std::lock_guard lock(impl_->mu);
  return impl_->stats;
}

}  // namespace peis::recorder
