// The run's trace in SQLite; see trace_writer.h. The schema (format
// "peis-trace 1", also in docs/scenarios.md):
//
//   recording(key TEXT PRIMARY KEY, value TEXT)
//       format, scenario, file, ecology, speed, started_us, ended_us, result
//   peis(id INTEGER PRIMARY KEY, name TEXT, program TEXT, pid INTEGER)
//       every PEIS of the run: the processes the runner started (pid) and
//       every other PEIS it saw (tiny nodes' proxies, hosted drivers; pid NULL)
//   tuple_events(seq INTEGER PRIMARY KEY, recv_us INTEGER, sim_s REAL,
//                event TEXT ('set' | 'delete'), owner INTEGER, key TEXT,
//                data BLOB, data_size INTEGER, mimetype TEXT,
//                encoding TEXT ('ascii' | 'binary'), creator INTEGER,
//                seqno INTEGER, ts_write INTEGER, ts_user INTEGER,
//                ts_expire INTEGER)
//       every tuple change seen, in the order seen; times in µs since the
//       Unix epoch (0 = not set); recv_us is the recorder's clock; sim_s the
//       scenario time; data NULL when the value was over the size limit
//   timeline(seq INTEGER PRIMARY KEY, recv_us INTEGER, sim_s REAL,
//            peis TEXT, words TEXT, tuple TEXT)
//       the lines the runner printed
//   conditions(name TEXT PRIMARY KEY, held INTEGER, at_s REAL, detail TEXT)
//       each success condition's verdict
#include "trace_writer.h"

#include <sqlite3.h>

#include <chrono>
#include <cstdio>
#include <stdexcept>

namespace peis::scenario {
namespace {

constexpr const char* kSchema = R"sql(
PRAGMA journal_mode = WAL;
PRAGMA synchronous = NORMAL;
CREATE TABLE recording (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE peis (id INTEGER PRIMARY KEY, name TEXT, program TEXT, pid INTEGER);
CREATE TABLE tuple_events (
  seq INTEGER PRIMARY KEY, recv_us INTEGER NOT NULL, sim_s REAL,
  event TEXT NOT NULL CHECK (event IN ('set', 'delete')),
  owner INTEGER NOT NULL, key TEXT NOT NULL, data BLOB, data_size INTEGER NOT NULL,
  mimetype TEXT, encoding TEXT, creator INTEGER, seqno INTEGER,
  ts_write INTEGER, ts_user INTEGER, ts_expire INTEGER);
CREATE INDEX tuple_events_by_key ON tuple_events (owner, key, seq);
CREATE TABLE timeline (seq INTEGER PRIMARY KEY, recv_us INTEGER, sim_s REAL,
                       peis TEXT, words TEXT, tuple TEXT);
CREATE TABLE conditions (name TEXT PRIMARY KEY, held INTEGER, at_s REAL, detail TEXT);
INSERT INTO recording VALUES ('format', 'peis-trace 1');
)sql";

std::int64_t nowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::int64_t us(Timestamp t) { return t.time_since_epoch().count(); }

void bindOptional(sqlite3_stmt* s, int i, std::optional<double> v) {
  if (v)
    sqlite3_bind_double(s, i, *v);
  else
    sqlite3_bind_null(s, i);
}

}  // namespace

TraceWriter::TraceWriter(const std::string& path, std::size_t maxData) : maxData_(maxData) {
  std::remove(path.c_str());
  for (const char* suffix : {"-wal", "-shm"}) std::remove((path + suffix).c_str());
  if (sqlite3_open(path.c_str(), &db_) != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw std::runtime_error("cannot create the trace " + path + ": " + why);
  }
  char* error = nullptr;
  if (sqlite3_exec(db_, kSchema, nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string why = error ? error : "?";
    sqlite3_free(error);
    sqlite3_close(db_);
    throw std::runtime_error("cannot create the trace " + path + ": " + why);
  }
  sqlite3_prepare_v2(
      db_,
      "INSERT INTO tuple_events (recv_us, sim_s, event, owner, key, data, data_size, "
      "mimetype, encoding, creator, seqno, ts_write, ts_user, ts_expire) VALUES "
      "(?,?,?,?,?,?,?,?,?,?,?,?,?,?)",
      -1, &insertTuple_, nullptr);
  sqlite3_prepare_v2(db_,
                     "INSERT INTO timeline (recv_us, sim_s, peis, words, tuple) VALUES (?,?,?,?,?)",
                     -1, &insertLine_, nullptr);
  thread_ = std::thread([this] { loop(); });
}

TraceWriter::~TraceWriter() { close(); }

void TraceWriter::info(const std::string& key, const std::string& value) { push(Info{key, value}); }
void TraceWriter::peis(long long id, const std::string& name, const std::string& program,
                       long long pid) {
  push(Peis{id, name, program, pid});
}
void TraceWriter::tuple(const Tuple& tuple, bool deleted, std::optional<double> sim) {
  push(TupleEvent{tuple, deleted, nowUs(), sim});
}
void TraceWriter::timeline(std::optional<double> sim, const std::string& peis,
                           const std::string& words, const std::string& tuple) {
  push(Line{nowUs(), sim, peis, words, tuple});
}
void TraceWriter::condition(const std::string& name, bool held, std::optional<double> at,
                            const std::string& detail) {
  push(Verdict{name, held, at, detail});
}

std::uint64_t TraceWriter::tuplesWritten() const {
  std::lock_guard lock(mu_);
  return tuples_;
}

void TraceWriter::push(Record record) {
  std::lock_guard lock(mu_);
  if (closing_) return;
  queue_.push_back(std::move(record));
  wake_.notify_one();
}

void TraceWriter::exec(const char* sql) { sqlite3_exec(db_, sql, nullptr, nullptr, nullptr); }

void TraceWriter::loop() {
  std::unique_lock lock(mu_);
  while (true) {
    wake_.wait_for(lock, std::chrono::milliseconds(200), [this] { return closing_; });
    std::deque<Record> batch;
    batch.swap(queue_);
    const bool last = closing_;
    lock.unlock();
    if (!batch.empty()) {
      exec("BEGIN");
      for (const auto& r : batch) write(r);
      exec("COMMIT");
    }
    lock.lock();
    if (last && queue_.empty()) return;
  }
}

void TraceWriter::write(const Record& record) {
  if (const auto* i = std::get_if<Info>(&record)) {
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(db_, "INSERT OR REPLACE INTO recording VALUES (?, ?)", -1, &s, nullptr);
    sqlite3_bind_text(s, 1, i->key.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(s, 2, i->value.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_step(s);
    sqlite3_finalize(s);
  } else if (const auto* p = std::get_if<Peis>(&record)) {
    sqlite3_stmt* s = nullptr;
    // A PEIS the runner started is known with its pid; keep that row.
    sqlite3_prepare_v2(db_,
                       "INSERT INTO peis VALUES (?, ?, ?, ?) ON CONFLICT (id) DO UPDATE SET "
                       "name = excluded.name, program = coalesce(excluded.program, program), "
                       "pid = coalesce(excluded.pid, pid)",
                       -1, &s, nullptr);
    sqlite3_bind_int64(s, 1, p->id);
    sqlite3_bind_text(s, 2, p->name.c_str(), -1, SQLITE_TRANSIENT);
    if (p->program.empty())
      sqlite3_bind_null(s, 3);
    else
      sqlite3_bind_text(s, 3, p->program.c_str(), -1, SQLITE_TRANSIENT);
    if (p->pid > 0)
      sqlite3_bind_int64(s, 4, p->pid);
    else
      sqlite3_bind_null(s, 4);
    sqlite3_step(s);
    sqlite3_finalize(s);
  } else if (const auto* e = std::get_if<TupleEvent>(&record)) {
    sqlite3_stmt* s = insertTuple_;
    const Tuple& t = e->tuple;
    sqlite3_reset(s);
    sqlite3_bind_int64(s, 1, e->recvUs);
    bindOptional(s, 2, e->sim);
    sqlite3_bind_text(s, 3, e->deleted ? "delete" : "set", -1, SQLITE_STATIC);
    sqlite3_bind_int64(s, 4, t.owner);
    sqlite3_bind_text(s, 5, t.key.c_str(), -1, SQLITE_TRANSIENT);
    if (e->deleted || t.data.size() > maxData_)
      sqlite3_bind_null(s, 6);
    else
      sqlite3_bind_blob(s, 6, t.data.data(), static_cast<int>(t.data.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(s, 7, static_cast<sqlite3_int64>(e->deleted ? 0 : t.data.size()));
    sqlite3_bind_text(s, 8, t.mimetype.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(s, 9, t.encoding == Encoding::Binary ? "binary" : "ascii", -1, SQLITE_STATIC);
    sqlite3_bind_int64(s, 10, t.creator);
    sqlite3_bind_int64(s, 11, static_cast<sqlite3_int64>(t.seqno));
    sqlite3_bind_int64(s, 12, us(t.ts_write));
    sqlite3_bind_int64(s, 13, us(t.ts_user));
    sqlite3_bind_int64(s, 14, us(t.ts_expire));
    if (sqlite3_step(s) == SQLITE_DONE) {
      std::lock_guard lock(mu_);
      ++tuples_;
    }
  } else if (const auto* l = std::get_if<Line>(&record)) {
    sqlite3_stmt* s = insertLine_;
    sqlite3_reset(s);
    sqlite3_bind_int64(s, 1, l->recvUs);
    bindOptional(s, 2, l->sim);
    sqlite3_bind_text(s, 3, l->peis.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(s, 4, l->words.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(s, 5, l->tuple.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_step(s);
  } else if (const auto* v = std::get_if<Verdict>(&record)) {
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(db_, "INSERT OR REPLACE INTO conditions VALUES (?, ?, ?, ?)", -1, &s,
                       nullptr);
    sqlite3_bind_text(s, 1, v->name.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(s, 2, v->held ? 1 : 0);
    bindOptional(s, 3, v->at);
    sqlite3_bind_text(s, 4, v->detail.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_step(s);
    sqlite3_finalize(s);
  }
}

void TraceWriter::close() {
  {
    std::lock_guard lock(mu_);
    if (closing_) {
      if (!thread_.joinable()) return;
    }
    closing_ = true;
    wake_.notify_one();
  }
  if (thread_.joinable()) thread_.join();
  if (db_) {
    sqlite3_finalize(insertTuple_);
    sqlite3_finalize(insertLine_);
    insertTuple_ = insertLine_ = nullptr;
    exec("PRAGMA wal_checkpoint(TRUNCATE)");
    exec("PRAGMA journal_mode = DELETE");
    sqlite3_close(db_);
    db_ = nullptr;
  }
}

}  // namespace peis::scenario
