// The schema of a recording and its checks (see recording_format.h).
#include "recorder/recording_format.h"

#include <peis/error.h>

#include <set>
#include <utility>
#include <vector>

namespace peis::recorder {
namespace {

// Every table a reader needs, and its columns.
const std::vector<std::pair<std::string, std::vector<std::string>>>& requiredTables() {
  static const std::vector<std::pair<std::string, std::vector<std::string>>> tables = {
      {"recording", {"name", "value"}},
      {"owners", {"id", "name"}},
      {"tuples", {"id", "owner", "key"}},
      {"events",
       {"id", "received", "tuple", "deleted", "creator", "seqno", "ts_write", "ts_user",
        "ts_expire", "mimetype", "encoding", "data"}},
  };
  return tables;
}

[[noreturn]] void notARecording(const Database& db, const std::string& why) {
  throw Error(ErrorCode::InvalidConfig, db.path() + ": not a PEIS recording (" + why + ")");
}

}  // namespace

void createSchema(Database& db) {
  db.exec("PRAGMA journal_mode = WAL");
  db.exec("PRAGMA synchronous = NORMAL");
  db.exec("PRAGMA application_id = " + std::to_string(kApplicationId));
  db.exec("PRAGMA user_version = " + std::to_string(kFormatVersion));
  db.exec(R"sql(
BEGIN;
CREATE TABLE recording (name TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE owners (id INTEGER PRIMARY KEY, name TEXT NOT NULL DEFAULT '');
CREATE TABLE tuples (id INTEGER PRIMARY KEY, owner INTEGER NOT NULL, key TEXT NOT NULL,
                     UNIQUE (owner, key));
CREATE TABLE events (
  id INTEGER PRIMARY KEY,
  received INTEGER NOT NULL,
  tuple INTEGER NOT NULL REFERENCES tuples(id),
  deleted INTEGER NOT NULL,
  creator INTEGER NOT NULL,
  seqno INTEGER NOT NULL,
  ts_write INTEGER NOT NULL,
  ts_user INTEGER NOT NULL,
  ts_expire INTEGER NOT NULL,
  mimetype TEXT NOT NULL,
  encoding INTEGER NOT NULL,
  data BLOB NOT NULL
);
CREATE VIEW history AS
  SELECT e.id, e.received, t.owner, t.key, e.deleted, e.creator, e.seqno, e.ts_write,
         e.ts_user, e.ts_expire, e.mimetype, e.encoding, e.data
  FROM events e JOIN tuples t ON t.id = e.tuple;
COMMIT;
)sql");
}

void checkRecording(Database& db) {
  std::set<std::string> tables;
  try {
    auto list = db.prepare("SELECT name FROM sqlite_schema WHERE type IN ('table', 'view')");
    while (list.step()) tables.insert(list.text(0));
  } catch (const Error&) {
    notARecording(db, std::string("not an SQLite database: ") + sqlite3_errmsg(db.handle()));
  }
  if (tables.count("recording") == 0)
    notARecording(db, tables.empty() ? "an empty SQLite database"
                                     : "an SQLite database without the table 'recording'");
  const std::string format = recordingValue(db, "format");
  if (format != kFormatName)
    notARecording(db,
                  "its recording table says format '" + format + "', not '" + kFormatName + "'");
  const std::string version = recordingValue(db, "version");
  if (version != std::to_string(kFormatVersion))
    throw Error(ErrorCode::InvalidConfig, db.path() + ": a recording of format version " + version +
                                              "; this program reads version " +
                                              std::to_string(kFormatVersion));
  for (const auto& [table, columns] : requiredTables()) {
    if (tables.count(table) == 0) notARecording(db, "the table '" + table + "' is missing");
    std::set<std::string> present;
    auto info = db.prepare("SELECT name FROM pragma_table_info('" + table + "')");
    while (info.step()) present.insert(info.text(0));
    for (const auto& column : columns) {
      if (present.count(column) == 0)
        notARecording(db, "the table '" + table + "' has no column '" + column + "'");
    }
  }
}

std::string recordingValue(Database& db, const std::string& name, const std::string& fallback) {
  auto s = db.prepare("SELECT value FROM recording WHERE name = ?1");
  s.bindText(1, name);
  return s.step() ? s.text(0) : fallback;
}

}  // namespace peis::recorder
