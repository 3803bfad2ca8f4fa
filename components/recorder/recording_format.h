// The recording file: an SQLite database in WAL mode, written by
// peis-record and read by peis-inspect, peis-replay and the sqlite3 shell.
// This is its schema (format 1); docs/operating.md explains it.
//
//   PRAGMA application_id = 1346717011;   -- 'PEIS'
//   PRAGMA user_version = 1;              -- the format
//   recording(name TEXT PRIMARY KEY, value TEXT)
//       format = peis-recording, version = 1, patterns, ecology, host,
//       recorder (PEIS id), started / ended (µs since the Unix epoch; ended
//       only after a clean stop), commit_interval_ms, dropped
//   owners(id INTEGER PRIMARY KEY, name TEXT)          -- the PEIS seen
//   tuples(id INTEGER PRIMARY KEY, owner INTEGER, key TEXT, UNIQUE(owner, key))
//   events(id INTEGER PRIMARY KEY,       -- order of arrival, from 1
//          received INTEGER,              -- µs since the epoch, the recorder's clock
//          tuple INTEGER REFERENCES tuples(id),
//          deleted INTEGER,               -- 0 a change, 1 a deletion
//          creator INTEGER, seqno INTEGER,
//          ts_write INTEGER, ts_user INTEGER, ts_expire INTEGER,  -- µs, 0 = not set
//          mimetype TEXT, encoding INTEGER,  -- 0 ascii, 1 binary
//          data BLOB)                     -- a deletion keeps the last value
//   VIEW history: events joined with tuples (owner, key) for reading by hand.
#pragma once

#include <cstdint>
#include <string>

#include "recorder/sqlite_db.h"

namespace peis::recorder {

inline constexpr int kFormatVersion = 1;
inline constexpr std::int64_t kApplicationId = 0x50454953;  // 'PEIS'
inline constexpr const char* kFormatName = "peis-recording";

// WAL, synchronous NORMAL, the tables and view of format 1, in a new file.
void createSchema(Database& db);

// Throws Error(InvalidConfig) naming the file and what is wrong unless it is
// a recording of a format this program reads: not an SQLite database, no
// recording table, another format or version, a missing table or column.
void checkRecording(Database& db);

// A value of the recording table, or `fallback`.
std::string recordingValue(Database& db, const std::string& name, const std::string& fallback = "");

}  // namespace peis::recorder
