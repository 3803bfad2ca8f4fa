// Recordings without a network: the writer thread commits by time (so a
// quiet recorder's file is complete without it exiting), every field of a
// tuple round-trips, a full queue drops and counts, and files that are not
// recordings are refused with a clear error.
#include <sqlite3.h>

#include <catch2/catch.hpp>
#include <filesystem>

#include "peis/error.h"
#include "recorder/inspect_report.h"
#include "recorder/recording_format.h"
#include "recorder/recording_reader.h"
#include "recorder/recording_writer.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

using namespace peis::recorder;
using namespace std::chrono_literals;
using peis::test::TempDir;
using peis::test::waitFor;

namespace {

peis::Timestamp at(long long us) { return peis::Timestamp(std::chrono::microseconds(us)); }

RecordedEvent event(long long received, const std::string& key, const std::string& data,
                    std::uint64_t seqno, bool deleted = false) {
  RecordedEvent e;
  e.received = at(received);
  e.deleted = deleted;
  e.tuple.owner = 12;
  e.tuple.creator = 7;
  e.tuple.key = key;
  e.tuple.data = data;
  e.tuple.seqno = seqno;
  e.tuple.ts_write = at(received - 100);
  return e;
}

// Events readable from another connection now (as peis-inspect would see them).
std::int64_t committedEvents(const std::string& path) {
  try {
    RecordingReader reader(path);
    return reader.summary().events();
  } catch (const peis::Error&) {
    return -1;
  }
}

std::string problemOf(const std::string& path) {
  try {
    RecordingReader reader(path);
  } catch (const peis::Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("commits come by time or by count, never for nothing", "[unit]") {
  WriterSettings s;
  s.commitInterval = 200ms;
  s.batchEvents = 100;
  const auto t0 = std::chrono::steady_clock::time_point{};
  CHECK_FALSE(shouldCommit(0, t0, t0 + 1s, s, true));
  CHECK_FALSE(shouldCommit(5, t0, t0 + 199ms, s, false));
  CHECK(shouldCommit(5, t0, t0 + 200ms, s, false));
  CHECK(shouldCommit(100, t0, t0, s, false));
  CHECK(shouldCommit(1, t0, t0, s, true));
}

TEST_CASE("a recording holds every field of every event, committed without more events", "[unit]") {
  TempDir dir("rec");
  const std::string path = dir.file("r.db");
  WriterSettings settings;
  settings.commitInterval = 50ms;
  RecordingWriter writer(path, {{"patterns", "12.**"}, {"ecology", "home"}, {"started", "1000"}},
                         settings, [](peis::PeisId) { return std::string("lamp"); }, {});
  auto binary = event(2000, "image", std::string("\x89PNG\0\x01", 6), 1);
  binary.tuple.mimetype = "image/png";
  binary.tuple.encoding = peis::Encoding::Binary;
  binary.tuple.ts_user = at(1500);
  binary.tuple.ts_expire = at(9000);
  writer.add(binary);
  writer.add(event(3000, "light.reqState", "on", 4));
  writer.add(event(4000, "light.reqState", "on", 5, true));
  // Nothing more arrives and the writer keeps running: the batch is committed by time.
  REQUIRE(waitFor([&] { return committedEvents(path) == 3; }, 20s));
  CHECK(writer.stats().written == 3);
  writer.finish({{"ended", "5000"}});
  const bool walLeft =
      std::filesystem::exists(path + "-wal") && std::filesystem::file_size(path + "-wal") > 0;
  CHECK_FALSE(walLeft);

  RecordingReader reader(path);
  StoredEvent e;
  REQUIRE(reader.next(e));
  CHECK(e.id == 1);
  CHECK(e.received == at(2000));
  CHECK_FALSE(e.deleted);
  CHECK(e.tuple == binary.tuple);
  REQUIRE(reader.next(e));
  CHECK(e.tuple.key == "light.reqState");
  CHECK(e.tuple.data == "on");
  CHECK(e.tuple.seqno == 4);
  REQUIRE(reader.next(e));
  CHECK(e.deleted);
  CHECK(e.tuple.seqno == 5);
  CHECK_FALSE(reader.next(e));

  const auto s = reader.summary();
  CHECK(s.changes == 2);
  CHECK(s.deletions == 1);
  CHECK(s.bytes == 8);
  CHECK(s.owners == std::map<peis::PeisId, std::string>{{12, "lamp"}});
  REQUIRE(s.tuples.size() == 2);
  CHECK(s.tuples[0].key == "image");
  CHECK(s.tuples[1].key == "light.reqState");
  CHECK(s.tuples[1].changes == 1);
  CHECK(s.tuples[1].deletions == 1);
  CHECK(s.started == at(1000));
  CHECK(s.ended == at(5000));
  CHECK(spanSeconds(s) == Approx(0.004));
  CHECK(s.values.at("format") == "peis-recording");
  CHECK(s.values.at("dropped") == "0");
}

TEST_CASE("a writer with too much waiting drops new events and counts them", "[unit]") {
  TempDir dir("rec");
  const std::string path = dir.file("r.db");
  WriterSettings settings;
  settings.commitInterval = 10s;  // nothing is written meanwhile
  settings.maxQueuedBytes = 3 * (sizeof(RecordedEvent) + 64);
  RecordingWriter writer(path, {}, settings, {}, {});
  for (int i = 0; i < 10; ++i) writer.add(event(1000 + i, "k", "v", i + 1));
  CHECK(writer.stats().dropped == 7);
  writer.finish({});
  RecordingReader reader(path);
  const auto s = reader.summary();
  CHECK(s.events() == 3);
  CHECK(s.values.at("dropped") == "7");
}

TEST_CASE("files that are not recordings are refused with a clear error", "[unit]") {
  TempDir dir("rec");
  CHECK(problemOf(dir.file("none.db")) == dir.file("none.db") + ": no such file");
  CHECK(problemOf(dir.path.string()) == dir.path.string() + ": a folder, not a recording");
  const auto text = dir.write("text.db", "just some text, not a database at all........\n");
  CHECK(problemOf(text) ==
        text + ": not a PEIS recording (not an SQLite database: file is not a database)");
  const auto sqlite = [&](const std::string& name, const std::string& sql) {
    const std::string path = dir.file(name);
    Database db(path, Database::Mode::Create);
    if (!sql.empty()) db.exec(sql);
    return path;
  };
  const auto empty = sqlite("empty.db", "");
  CHECK(problemOf(empty) == empty + ": not a PEIS recording (an empty SQLite database)");
  const auto other = sqlite("other.db", "CREATE TABLE messages (id INTEGER, topic TEXT)");
  CHECK(problemOf(other) ==
        other + ": not a PEIS recording (an SQLite database without the table 'recording')");
  const auto otherFormat = sqlite("format.db",
                                  "CREATE TABLE recording (name TEXT, value TEXT);"
                                  "INSERT INTO recording VALUES ('format', 'rosbag2')");
  CHECK(problemOf(otherFormat) == otherFormat +
                                      ": not a PEIS recording (its recording table says format "
                                      "'rosbag2', not 'peis-recording')");
  const auto future =
      sqlite("future.db",
             "CREATE TABLE recording (name TEXT, value TEXT);"
             "INSERT INTO recording VALUES ('format', 'peis-recording'), ('version', '7')");
  CHECK(problemOf(future) ==
        future + ": a recording of format version 7; this program reads version 1");
  // A recording whose events table lost a column.
  const auto broken = dir.file("broken.db");
  {
    Database db(broken, Database::Mode::Create);
    createSchema(db);
    db.exec(
        "INSERT INTO recording VALUES ('format', 'peis-recording'), ('version', '1');"
        "DROP VIEW history; ALTER TABLE events DROP COLUMN seqno");
  }
  CHECK(problemOf(broken) ==
        broken + ": not a PEIS recording (the table 'events' has no column 'seqno')");
}

TEST_CASE("inspect reports the span, totals, rates and one line per tuple", "[unit]") {
  RecordingSummary s;
  s.values = {{"format", "peis-recording"}, {"version", "1"}, {"commit_interval_ms", "200"},
              {"recorder", "99"},           {"host", "vm"},   {"ecology", "home"},
              {"patterns", "12.**"},        {"dropped", "0"}};
  s.owners = {{12, "lamp"}};
  s.started = at(1'700'000'000'000'000);
  s.first = at(1'700'000'000'500'000);
  s.last = at(1'700'000'002'000'000);
  s.ended = at(1'700'000'004'000'000);
  s.changes = 8;
  s.deletions = 2;
  s.bytes = 2048;
  s.tuples = {{12, "light", 8, 2, 2048, s.first, s.last}};
  CHECK(inspectText(s, "r.db") ==
        "r.db\n"
        "  format      peis-recording 1, commit interval 200 ms\n"
        "  recorded    by PEIS 99 on vm, ecology 'home', patterns 12.**\n"
        "  span        2023-11-14 22:13:20.000 .. 2023-11-14 22:13:24.000 UTC (4.000 s)\n"
        "  ended       cleanly\n"
        "  events      10: 8 changes, 2 deletions; 2.5 /s; 2.0 KiB of data\n"
        "  owners      12 (lamp)\n"
        "  dropped     0\n"
        "\n"
        "TUPLE      CHANGES DELETIONS     RATE/S        BYTES    FIRST S     LAST S\n"
        "12.light         8         2       2.50         2048      0.500      2.000\n");
  s.ended.reset();
  CHECK(spanSeconds(s) == Approx(2.0));
  const auto json = inspectJson(s, "r.db");
  CHECK(json.find("\"clean\":false") != std::string::npos);
  CHECK(json.find("\"tuples\":[{\"owner\":12,\"key\":\"light\",\"changes\":8") !=
        std::string::npos);
  // Names are escaped by the one JSON escaping (peis/json_string.h).
  CHECK(inspectJson(s, "a\"b\n\xff.db").find("{\"file\":\"a\\\"b\\n\xEF\xBF\xBD.db\"") !=
        std::string::npos);
}

TEST_CASE("a stand-in replay needs only the owners with tuples beyond kernel.*", "[unit]") {
  TempDir dir("rec");
  const std::string path = dir.file("r.db");
  {
    RecordingWriter writer(path, {}, {}, {}, {});
    auto tool = event(1000, "kernel.name", "peis-get", 1);
    tool.tuple.owner = 13;
    writer.add(tool);
    writer.add(event(2000, "kernel.name", "lamp", 1));
    writer.add(event(3000, "light", "on", 1));
    writer.finish({});
  }
  RecordingReader reader(path);
  CHECK(reader.owners().size() == 2);
  CHECK(reader.owners(true) == std::map<peis::PeisId, std::string>{{12, ""}});
}
