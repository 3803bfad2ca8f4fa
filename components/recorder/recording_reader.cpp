// Reading a recording (see recording_reader.h).
#include "recorder/recording_reader.h"

#include <peis/error.h>

#include <ctime>
#include <filesystem>

#include "recorder/recording_format.h"

namespace peis::recorder {
namespace {

Timestamp fromMicros(std::int64_t us) { return Timestamp(std::chrono::microseconds(us)); }

std::optional<Timestamp> timeValue(const std::map<std::string, std::string>& values,
                                   const std::string& name) {
  const auto it = values.find(name);
  if (it == values.end() || it->second.empty()) return std::nullopt;
  try {
    return fromMicros(std::stoll(it->second));
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

}  // namespace

RecordingReader::RecordingReader(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw Error(ErrorCode::InvalidConfig, path + ": no such file");
  if (std::filesystem::is_directory(path, ec))
    throw Error(ErrorCode::InvalidConfig, path + ": a folder, not a recording");
  db_ = std::make_unique<Database>(path, Database::Mode::ReadOnly);
  checkRecording(*db_);
}

RecordingReader::~RecordingReader() = default;

std::map<PeisId, std::string> RecordingReader::owners(bool beyondKernel) {
  std::map<PeisId, std::string> result;
  auto s = db_->prepare(std::string("SELECT DISTINCT t.owner, coalesce(o.name, '') FROM tuples t "
                                    "LEFT JOIN owners o ON o.id = t.owner ") +
                        (beyondKernel ? "WHERE substr(t.key, 1, 7) != 'kernel.' " : "") +
                        "ORDER BY t.owner");
  while (s.step()) result[static_cast<PeisId>(s.integer(0))] = s.text(1);
  return result;
}

RecordingSummary RecordingReader::summary() {
  RecordingSummary r;
  auto values = db_->prepare("SELECT name, value FROM recording");
  while (values.step()) r.values[values.text(0)] = values.text(1);
  r.started = timeValue(r.values, "started");
  r.ended = timeValue(r.values, "ended");
  r.owners = owners();
  auto s = db_->prepare(
      "SELECT t.owner, t.key, sum(e.deleted = 0), sum(e.deleted), "
      "sum(CASE WHEN e.deleted = 0 THEN length(e.data) ELSE 0 END), min(e.received), "
      "max(e.received) FROM events e JOIN tuples t ON t.id = e.tuple "
      "GROUP BY e.tuple ORDER BY t.owner, t.key");
  bool any = false;
  while (s.step()) {
    TupleSummary t;
    t.owner = static_cast<PeisId>(s.integer(0));
    t.key = s.text(1);
    t.changes = s.integer(2);
    t.deletions = s.integer(3);
    t.bytes = s.integer(4);
    t.first = fromMicros(s.integer(5));
    t.last = fromMicros(s.integer(6));
    r.changes += t.changes;
    r.deletions += t.deletions;
    r.bytes += t.bytes;
    r.first = any ? std::min(r.first, t.first) : t.first;
    r.last = any ? std::max(r.last, t.last) : t.last;
    any = true;
    r.tuples.push_back(std::move(t));
  }
  return r;
}

void RecordingReader::rewind() {
  events_ = std::make_unique<Statement>(db_->prepare(
      "SELECT e.id, e.received, t.owner, t.key, e.deleted, e.creator, e.seqno, e.ts_write, "
      "e.ts_user, e.ts_expire, e.mimetype, e.encoding, e.data FROM events e "
      "JOIN tuples t ON t.id = e.tuple ORDER BY e.id"));
}

bool RecordingReader::next(StoredEvent& e) {
  if (!events_) rewind();
  if (!events_->step()) return false;
  const Statement& s = *events_;
  e.id = s.integer(0);
  e.received = fromMicros(s.integer(1));
  e.tuple.owner = static_cast<PeisId>(s.integer(2));
  e.tuple.key = s.text(3);
  e.deleted = s.integer(4) != 0;
  e.tuple.creator = static_cast<PeisId>(s.integer(5));
  e.tuple.seqno = static_cast<std::uint64_t>(s.integer(6));
  e.tuple.ts_write = fromMicros(s.integer(7));
  e.tuple.ts_user = fromMicros(s.integer(8));
  e.tuple.ts_expire = fromMicros(s.integer(9));
  e.tuple.mimetype = s.text(10);
  e.tuple.encoding = s.integer(11) != 0 ? Encoding::Binary : Encoding::Ascii;
  e.tuple.data = s.blob(12);
  return true;
}

std::string formatTime(Timestamp t) {
  const auto us = t.time_since_epoch().count();
  const std::time_t seconds = static_cast<std::time_t>(us / 1000000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[64];
  std::snprintf(text, sizeof text, "%04d-%02d-%02d %02d:%02d:%02d.%03d", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec,
                static_cast<int>((us % 1000000) / 1000));
  return text;
}

}  // namespace peis::recorder
