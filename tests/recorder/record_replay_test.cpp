// peis-record, peis-inspect and peis-replay as separate processes in an
// ecology of their own: a round trip (record -> inspect -> the sqlite3
// shell -> replay as a stand-in and under a prefix, a subscriber seeing the
// same sequence), a replay refused while the recorded owner is alive, a
// recorder killed with SIGKILL (quiet: nothing lost; mid-stream: an intact
// file whose events are a gap-free prefix), and bad files and options.
#include <signal.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <filesystem>
#include <regex>
#include <thread>

#include "recorder/recording_reader.h"
#include "recorder/sqlite_db.h"
#include "support/integration.h"
#include "support/temp_dir.h"

using namespace peis::test;
using namespace std::chrono_literals;

namespace {

// A recorder process of `writer`'s tuples `keys` into `file`, once its
// subscription has reached the writer.
struct RecorderProcess {
  std::unique_ptr<Process> process;
  peis::PeisId id = 0;

  RecorderProcess(const std::string& ecology, peis::Kernel& writer, const std::string& keys,
                  const std::string& file) {
    process = std::make_unique<Process>(
        std::vector<std::string>{PEIS_RECORD_PATH, std::to_string(writer.id()) + "." + keys, "-o",
                                 file, "--peis-ecology", ecology});
    static const std::regex line(R"(peis-record: PEIS (\d+) records)");
    std::smatch match;
    waitFor(
        [&] {
          const std::string err = process->err();
          if (std::regex_search(err, match, line)) id = std::stoi(match[1]);
          return id != 0 || !process->running();
        },
        kDeadline);
    INFO(process->describe());
    REQUIRE(id != 0);
    REQUIRE(waitFor(
        [&] { return listContains(valueOf(writer, writer.id(), "kernel.subscribers"), id); },
        kDeadline));
  }
};

// Events committed in the file now, as another reader sees them.
std::int64_t eventsIn(const std::string& path) {
  try {
    peis::recorder::RecordingReader reader(path);
    return reader.summary().events();
  } catch (const peis::Error&) {
    return -1;
  }
}

CliResult runProgram(std::vector<std::string> argv,
                     std::chrono::milliseconds deadline = kDeadline) {
  Process p(std::move(argv));
  const auto status = p.wait(deadline);
  INFO(p.describe());
  REQUIRE(status.has_value());
  return CliResult{*status, p.out(), p.err()};
}

// What a subscriber saw, one line per event: "key=data" or "key deleted".
struct Sequence {
  Recorder seen;
  void watch(peis::Kernel& k, const peis::Pattern& pattern) {
    k.onChange(pattern, [this](const peis::Tuple& t) { seen.add(t.key + "=" + t.data); });
    k.onDelete(pattern, [this](const peis::Tuple& t) { seen.add(t.key + " deleted"); });
    k.subscribe(pattern);
  }
};

}  // namespace

TEST_CASE("record, inspect and replay: a subscriber sees the same sequence again",
          "[integration]") {
  const std::string ecology = uniqueEcology("record-roundtrip");
  TempDir dir("record");
  const std::string file = dir.file("home.db");
  std::vector<std::string> written;  // the sequence as the writer made it
  peis::PeisId writerId = 0;
  {
    peis::Kernel writer(kernelOptions(ecology, "writer"));
    writerId = writer.id();
    RecorderProcess recorder(ecology, writer, "seq.**", file);
    StateReport report([&] { return recorder.process->describe(); });
    for (int i = 1; i <= 20; ++i) {
      writer.set("seq.a", std::to_string(i));
      written.push_back("seq.a=" + std::to_string(i));
    }
    REQUIRE_WAIT([&] { return eventsIn(file) == 20; }, kDeadline);
    peis::WriteOptions png;
    png.mimetype = "image/png";
    png.encoding = peis::Encoding::Binary;
    writer.set("seq.b", std::string("\x89PNG\0", 5), png);
    written.push_back("seq.b=" + std::string("\x89PNG\0", 5));
    writer.erase("seq.a");
    written.push_back("seq.a deleted");
    writer.set("seq.a", "again");
    written.push_back("seq.a=again");
    REQUIRE_WAIT([&] { return eventsIn(file) == 23; }, kDeadline);
    recorder.process->kill(SIGINT);
    const auto status = recorder.process->wait(kDeadline);
    REQUIRE(status);
    CHECK(*status == 0);
    CHECK(recorder.process->err().find("23 events (22 changes, 1 deletions)") != std::string::npos);

    peis::recorder::RecordingReader reader(file);
    peis::recorder::StoredEvent e;
    for (int i = 1; i <= 21; ++i) REQUIRE(reader.next(e));
    CHECK(e.tuple.mimetype == "image/png");
    CHECK(e.tuple.encoding == peis::Encoding::Binary);
    CHECK(e.tuple.owner == writerId);
    CHECK(e.tuple.creator == writerId);
    CHECK(e.tuple.seqno == 1);
  }  // the writer is gone: its stand-in may take its id

  // peis-inspect
  const auto inspect = runProgram({PEIS_INSPECT_PATH, file});
  INFO(inspect.out + inspect.err);
  CHECK(inspect.status == 0);
  CHECK(inspect.out.find("  events      23: 22 changes, 1 deletions;") != std::string::npos);
  CHECK(inspect.out.find("  ended       cleanly") != std::string::npos);
  CHECK(inspect.out.find("  owners      " + std::to_string(writerId) + " (writer)") !=
        std::string::npos);
  CHECK(
      std::regex_search(inspect.out, std::regex(std::to_string(writerId) + R"(\.seq\.a +21 +1 )")));
  CHECK(
      std::regex_search(inspect.out, std::regex(std::to_string(writerId) + R"(\.seq\.b +1 +0 )")));
  const auto json = runProgram({PEIS_INSPECT_PATH, file, "--json"});
  CHECK(json.out.find("\"events\":23,\"changes\":22,\"deletions\":1") != std::string::npos);

  // The documented view, through the sqlite3 shell.
  const auto shell =
      runProgram({"/usr/bin/sqlite3", file,
                  "SELECT owner, key, seqno, deleted, CAST(data AS TEXT) FROM history "
                  "WHERE key = 'seq.a' ORDER BY id DESC LIMIT 2"});
  CHECK(shell.status == 0);
  CHECK(shell.out == std::to_string(writerId) + "|seq.a|22|0|again\n" + std::to_string(writerId) +
                         "|seq.a|21|1|20\n");

  SECTION("as a stand-in with the writer's id") {
    peis::Kernel subscriber(kernelOptions(ecology, "subscriber"));
    Sequence sequence;
    sequence.watch(subscriber, peis::Pattern("seq.**", writerId));
    const auto replay = runProgram({PEIS_REPLAY_PATH, file, "--wait-subscribers", "1", "--wait",
                                    "1", "--speed", "4", "--peis-ecology", ecology},
                                   60s);
    INFO(replay.err);
    CHECK(replay.status == 0);
    CHECK(replay.err.find("23 events (1 deletions) in 1 pass(es), 0 skipped") != std::string::npos);
    REQUIRE_WAIT([&] { return sequence.seen.entries().size() >= written.size(); }, kDeadline);
    CHECK(sequence.seen.entries() == written);
    const auto b = subscriber.get(writerId, "seq.b");
    REQUIRE(b);
    CHECK(b->mimetype == "image/png");
    CHECK(b->encoding == peis::Encoding::Binary);
    CHECK(b->creator == writerId);
  }
  SECTION("under a prefix, faster") {
    peis::Kernel subscriber(kernelOptions(ecology, "subscriber"));
    Sequence sequence;
    sequence.watch(subscriber, peis::Pattern("old.**"));
    const auto replay = runProgram({PEIS_REPLAY_PATH, file, "--prefix", "old", "--speed", "10",
                                    "--wait-subscribers", "1", "--peis-ecology", ecology},
                                   60s);
    INFO(replay.err);
    CHECK(replay.status == 0);
    REQUIRE_WAIT([&] { return sequence.seen.entries().size() >= written.size(); }, kDeadline);
    std::vector<std::string> prefixed;
    for (const auto& line : written)
      prefixed.push_back("old." + std::to_string(writerId) + "." + line);
    CHECK(sequence.seen.entries() == prefixed);
  }
}

TEST_CASE("record --duration stops by itself, replay --loop goes on until stopped",
          "[integration]") {
  const std::string ecology = uniqueEcology("record-loop");
  TempDir dir("record");
  const std::string file = dir.file("loop.db");
  peis::PeisId writerId = 0;
  {
    peis::Kernel writer(kernelOptions(ecology, "writer"));
    writerId = writer.id();
    writer.set("v", "a");  // found by the subscription: recorded as the first value
    Process recorder({PEIS_RECORD_PATH, std::to_string(writerId) + ".v", "-o", file, "--duration",
                      "1", "--peis-ecology", ecology});
    REQUIRE_WAIT([&] { return eventsIn(file) == 1; }, kDeadline);
    writer.set("v", "b");
    const auto status = recorder.wait(kDeadline);
    INFO(recorder.describe());
    REQUIRE(status == 0);
    CHECK(recorder.err().find("--duration reached") != std::string::npos);
  }
  REQUIRE(eventsIn(file) == 2);
  peis::Kernel subscriber(kernelOptions(ecology, "subscriber"));
  Sequence sequence;
  sequence.watch(subscriber, peis::Pattern("again.**"));
  Process replay({PEIS_REPLAY_PATH, file, "--prefix", "again", "--loop", "--speed", "100",
                  "--wait-subscribers", "1", "--peis-ecology", ecology});
  StateReport report([&] { return replay.describe() + sequence.seen.text(); });
  REQUIRE_WAIT([&] { return sequence.seen.entries().size() >= 6; }, kDeadline);
  replay.kill(SIGINT);
  const auto status = replay.wait(kDeadline);
  REQUIRE(status == 0);
  const std::string a = "again." + std::to_string(writerId) + ".v=a",
                    b = "again." + std::to_string(writerId) + ".v=b";
  const auto seen = sequence.seen.entries();
  CHECK(std::vector<std::string>(seen.begin(), seen.begin() + 6) ==
        std::vector<std::string>{a, b, a, b, a, b});
  CHECK(std::regex_search(replay.err(), std::regex(R"(in [3-9]\d* pass\(es\)|in \d{2,} pass)")));
}

TEST_CASE("the replay keeps the recorded timing", "[integration]") {
  const std::string ecology = uniqueEcology("record-timing");
  TempDir dir("record");
  const std::string file = dir.file("t.db");
  peis::PeisId writerId = 0;
  {
    peis::Kernel writer(kernelOptions(ecology, "writer"));
    writerId = writer.id();
    RecorderProcess recorder(ecology, writer, "t", file);
    writer.set("t", "1");
    REQUIRE_WAIT([&] { return eventsIn(file) == 1; }, kDeadline);  // some time passes
    writer.set("t", "2");
    REQUIRE_WAIT([&] { return eventsIn(file) == 2; }, kDeadline);
    recorder.process->kill(SIGTERM);
    REQUIRE(recorder.process->wait(kDeadline) == 0);
  }
  peis::recorder::RecordingReader reader(file);
  peis::recorder::StoredEvent first, second;
  REQUIRE(reader.next(first));
  REQUIRE(reader.next(second));
  const auto recordedGap = second.received - first.received;

  peis::Kernel subscriber(kernelOptions(ecology, "subscriber"));
  Recorder stamps;
  subscriber.onChange(peis::Pattern("t", writerId), [&](const peis::Tuple& t) {
    stamps.add(std::to_string(t.ts_write.time_since_epoch().count()));
  });
  subscriber.subscribe(peis::Pattern("t", writerId));
  const auto replay = runProgram({PEIS_REPLAY_PATH, file, "--wait-subscribers", "1", "--wait", "1",
                                  "--speed", "2", "--peis-ecology", ecology},
                                 60s);
  CHECK(replay.status == 0);
  REQUIRE_WAIT([&] { return stamps.entries().size() == 2; }, kDeadline);
  const auto replayedGap =
      std::chrono::microseconds(std::stoll(stamps.entries()[1]) - std::stoll(stamps.entries()[0]));
  // A replay may be late on a loaded machine, never faster: each event comes
  // at least its recorded gap after the one before, divided by the speed
  // (1 ms for the rounding of stamps).
  INFO("recorded gap " << recordedGap.count() << " us, replayed " << replayedGap.count() << " us");
  CHECK(replayedGap >= recordedGap / 2 - 1ms);
}

TEST_CASE("a stand-in replay is refused while the recorded owner is alive", "[integration]") {
  const std::string ecology = uniqueEcology("record-alive");
  TempDir dir("record");
  const std::string file = dir.file("alive.db");
  peis::Kernel writer(kernelOptions(ecology, "writer"));
  const auto writerId = writer.id();
  {
    RecorderProcess recorder(ecology, writer, "x", file);
    writer.set("x", "1");
    REQUIRE_WAIT([&] { return eventsIn(file) == 1; }, kDeadline);
    recorder.process->kill(SIGINT);
    REQUIRE(recorder.process->wait(kDeadline) == 0);
  }
  const auto replay =
      runProgram({PEIS_REPLAY_PATH, file, "--wait", "10", "--peis-ecology", ecology}, 60s);
  CHECK(replay.status == 1);
  CHECK(replay.err.find("PEIS " + std::to_string(writerId) +
                        " (writer) of the recording is alive") != std::string::npos);
  CHECK(valueOf(writer, writerId, "x") == "1");  // untouched
  CHECK(writer.id() == writerId);
}

TEST_CASE("a recorder killed with SIGKILL leaves an intact recording", "[fault]") {
  const std::string ecology = uniqueEcology("record-kill");
  TempDir dir("record");
  peis::Kernel writer(kernelOptions(ecology, "writer"));
  const auto integrity = [](const std::string& path) {
    peis::recorder::Database db(path, peis::recorder::Database::Mode::ReadOnly);
    auto check = db.prepare("PRAGMA integrity_check");
    return check.step() ? check.text(0) : std::string("no answer");
  };

  SECTION("killed while quiet: nothing is lost, though it never exited") {
    const std::string file = dir.file("quiet.db");
    RecorderProcess recorder(ecology, writer, "n", file);
    for (int i = 1; i <= 100; ++i) writer.set("n", std::to_string(i));
    REQUIRE_WAIT([&] { return eventsIn(file) == 100; }, kDeadline);
    recorder.process->kill(SIGKILL);
    REQUIRE(recorder.process->wait(kDeadline) == -SIGKILL);
    CHECK(integrity(file) == "ok");
    CHECK(eventsIn(file) == 100);
    const auto inspect = runProgram({PEIS_INSPECT_PATH, file});
    CHECK(inspect.status == 0);
    CHECK(inspect.out.find("ended       no: the recorder did not stop cleanly") !=
          std::string::npos);
  }
  SECTION("killed mid-stream: an intact file, a gap-free prefix of the stream") {
    const std::string file = dir.file("stream.db");
    RecorderProcess recorder(ecology, writer, "n", file);
    std::atomic<bool> stop{false};
    std::atomic<std::uint64_t> lastWritten{0};
    std::thread stream([&] {
      while (!stop) {
        lastWritten = writer.set("n", "value").seqno;
        std::this_thread::sleep_for(1ms);
      }
    });
    // Kill it once some batches are committed and more are arriving.
    const bool committed = waitFor([&] { return eventsIn(file) >= 300; }, kDeadline);
    recorder.process->kill(SIGKILL);
    const auto writtenAtKill = lastWritten.load();
    stop = true;
    stream.join();
    REQUIRE(committed);
    REQUIRE(recorder.process->wait(kDeadline) == -SIGKILL);
    CHECK(integrity(file) == "ok");
    peis::recorder::RecordingReader reader(file);
    peis::recorder::StoredEvent e;
    std::uint64_t previous = 0, count = 0;
    bool gapFree = true;
    while (reader.next(e)) {
      gapFree = gapFree && (previous == 0 || e.tuple.seqno == previous + 1);
      previous = e.tuple.seqno;
      ++count;
    }
    INFO("written " << writtenAtKill << ", recorded up to seqno " << previous << " (" << count
                    << " events)");
    CHECK(gapFree);
    CHECK(count >= 300);
    CHECK(previous <= writtenAtKill);
    const auto inspect = runProgram({PEIS_INSPECT_PATH, file});
    CHECK(inspect.status == 0);
  }
}

TEST_CASE("the recording programs refuse bad files and options clearly", "[unit]") {
  TempDir dir("record-bad");
  const auto text = dir.write("notes.db", "these are notes, not a database, really not.\n");
  {
    peis::recorder::Database other(dir.file("other.db"), peis::recorder::Database::Mode::Create);
    other.exec("CREATE TABLE messages (id INTEGER)");
  }
  auto r = runProgram({PEIS_INSPECT_PATH, text});
  CHECK(r.status == 1);
  CHECK(r.err == "peis-inspect: " + text +
                     ": not a PEIS recording (not an SQLite database: file is not a database)\n");
  r = runProgram({PEIS_INSPECT_PATH, dir.file("other.db")});
  CHECK(r.status == 1);
  CHECK(r.err == "peis-inspect: " + dir.file("other.db") +
                     ": not a PEIS recording (an SQLite database without the table 'recording')\n");
  r = runProgram({PEIS_REPLAY_PATH, text});
  CHECK(r.status == 1);
  CHECK(r.err.find("not a PEIS recording") != std::string::npos);
  r = runProgram({PEIS_RECORD_PATH, "*.**", "-o", text});
  CHECK(r.status == 2);
  CHECK(r.err == "peis-record: " + text + " exists; --force replaces it (see --help)\n");
  r = runProgram({PEIS_RECORD_PATH, "*.**"});
  CHECK(r.status == 2);
  CHECK(r.err == "peis-record: -o FILE.db is needed (see --help)\n");
  r = runProgram({PEIS_REPLAY_PATH, text, "--speed", "0"});
  CHECK(r.status == 2);
  r = runProgram({PEIS_INSPECT_PATH});
  CHECK(r.status == 2);
  // `peis inspect` runs peis-inspect, as git runs git-FOO.
  {
    const std::string inspectDir = std::filesystem::path(PEIS_INSPECT_PATH).parent_path();
    Process viaPeis({PEIS_CLI_PATH, "inspect", text}, {{"PEIS_EXEC_PATH", inspectDir}});
    const auto status = viaPeis.wait(kDeadline);
    INFO(viaPeis.describe());
    CHECK(status == 1);
    CHECK(viaPeis.err().find(text + ": not a PEIS recording") != std::string::npos);
  }
  for (const char* program : {PEIS_RECORD_PATH, PEIS_INSPECT_PATH, PEIS_REPLAY_PATH}) {
    r = runProgram({program, "--help"});
    CHECK(r.status == 0);
    CHECK(r.out.find("Usage: peis-") == 0);
  }
}
