// The run's trace: every tuple change the runner sees, the timeline, the
// PEIS and the verdicts, in one SQLite file (schema in trace_writer.cpp and
// docs/scenarios.md, "The trace"). Records are queued by any thread and
// written by a thread of its own in transactions of at most 200 ms, so a
// callback never waits for the disk; close() (or the destructor) writes
// what is queued and commits, so an interrupted run keeps its trace.
#pragma once

#include <peis/tuple.h>

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>

struct sqlite3;
struct sqlite3_stmt;

namespace peis::scenario {

class TraceWriter {
 public:
  // Creates `path` (replacing a file of that name); throws std::runtime_error
  // naming the file when SQLite cannot. `maxData`: larger values are
  // recorded by their size only.
  TraceWriter(const std::string& path, std::size_t maxData);
  TraceWriter(const TraceWriter&) = delete;
  TraceWriter& operator=(const TraceWriter&) = delete;
  ~TraceWriter();

  void info(const std::string& key, const std::string& value);
  void peis(long long id, const std::string& name, const std::string& program, long long pid);
  void tuple(const Tuple& tuple, bool deleted, std::optional<double> simSeconds);
  void timeline(std::optional<double> simSeconds, const std::string& peis, const std::string& words,
                const std::string& tuple);
  void condition(const std::string& name, bool held, std::optional<double> atSeconds,
                 const std::string& detail);
  // Writes everything queued and closes the file. Idempotent.
  void close();
  std::uint64_t tuplesWritten() const;

 private:
  struct Info {
    std::string key, value;
  };
  struct Peis {
    long long id;
    std::string name, program;
    long long pid;
  };
  struct TupleEvent {
    Tuple tuple;
    bool deleted;
    std::int64_t recvUs;
    std::optional<double> sim;
  };
  struct Line {
    std::int64_t recvUs;
    std::optional<double> sim;
    std::string peis, words, tuple;
  };
  struct Verdict {
    std::string name;
    bool held;
    std::optional<double> at;
    std::string detail;
  };
  using Record = std::variant<Info, Peis, TupleEvent, Line, Verdict>;

  void push(Record record);
  void loop();
  void write(const Record& record);
  void exec(const char* sql);

  sqlite3* db_ = nullptr;
  sqlite3_stmt *insertTuple_ = nullptr, *insertLine_ = nullptr;
  std::size_t maxData_;
  mutable std::mutex mu_;
  std::condition_variable wake_;
  std::deque<Record> queue_;
  bool closing_ = false;
  std::uint64_t tuples_ = 0;
  std::thread thread_;
};

}  // namespace peis::scenario
