// peis-bench-record: does a recorder keep up? A writer PEIS (this process)
// writes distinct 16-byte values at a paced rate (default 100,000 updates/s
// over 1,000 keys, for 30 s); peis-record, a separate process, records them
// all. Afterwards the recording is compared with what was written: events
// recorded, gaps in each key's seqnos (updates merged before they reached
// the recorder: coalesced) and the writer's own coalesced counter. The
// recorder's CPU time (wait4) and the file's size give CPU and disk per
// update. Prints one Markdown table row; docs/performance.md explains it.
//
//   peis-bench-record --record build/components/recorder/peis-record
//                     [--rate N] [--seconds S] [--keys K] [--dir DIR]
#include <fcntl.h>
#include <peis/kernel.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "recorder/sqlite_db.h"

extern char** environ;

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

struct Settings {
  std::string record;  // the peis-record program
  std::string dir = "/tmp";
  double rate = 100000;
  double seconds = 30;
  int keys = 1000;
};

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::int64_t eventsIn(const std::string& path) {
  try {
    peis::recorder::Database db(path, peis::recorder::Database::Mode::ReadOnly);
    return db.scalar("SELECT coalesce(max(id), 0) FROM events");
  } catch (const peis::Error&) {
    return 0;
  }
}

bool parse(int argc, char** argv, Settings& s) {
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string name = argv[i], value = argv[i + 1];
    if (name == "--record")
      s.record = value;
    else if (name == "--dir")
      s.dir = value;
    else if (name == "--rate")
      s.rate = std::stod(value);
    else if (name == "--seconds")
      s.seconds = std::stod(value);
    else if (name == "--keys")
      s.keys = std::stoi(value);
    else
      return false;
  }
  return argc % 2 == 1 && !s.record.empty() && s.rate > 0 && s.seconds > 0 && s.keys > 0;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  if (!parse(argc, argv, s)) {
    std::cerr << "usage: peis-bench-record --record PATH [--rate N] [--seconds S] [--keys K] "
                 "[--dir DIR]\n";
    return 2;
  }
  const std::string ecology = "bench-record-" + std::to_string(::getpid());
  const std::string file = s.dir + "/peis-bench-record-" + std::to_string(::getpid()) + ".db";
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(file + suffix);

  peis::Options options;
  options.ecology = ecology;
  options.name = "bench-writer";
  peis::Kernel writer(options);
  const std::string pattern = std::to_string(writer.id()) + ".bench.**";
  std::vector<std::string> args{s.record, pattern, "-o", file, "--peis-ecology", ecology};
  std::vector<char*> argv2;
  for (auto& a : args) argv2.push_back(a.data());
  argv2.push_back(nullptr);
  pid_t recorder = -1;
  // Its stderr (the summary line with the longest commit) goes to a file.
  const std::string log = file + ".log";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int spawned =
      posix_spawn(&recorder, s.record.c_str(), &actions, nullptr, argv2.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    std::cerr << "cannot start " << s.record << "\n";
    return 1;
  }
  // The recorder's subscription has reached the writer.
  const auto joinBy = Clock::now() + 30s;
  while (Clock::now() < joinBy) {
    const auto subscribers = writer.get(peis::special::kSubscribers);
    if (subscribers && !subscribers->data.empty()) break;
    std::this_thread::sleep_for(10ms);
  }

  std::vector<std::string> keys;
  for (int k = 0; k < s.keys; ++k) keys.push_back("bench.k" + std::to_string(k));
  const auto start = Clock::now();
  std::uint64_t written = 0;
  char value[17];
  while (since(start) < s.seconds) {
    const auto due = static_cast<std::uint64_t>(since(start) * s.rate);
    while (written < due) {
      std::snprintf(value, sizeof value, "%016" PRIu64, written);  // 16 distinct bytes
      writer.set(keys[written % keys.size()], std::string(value, 16));
      ++written;
    }
    std::this_thread::sleep_for(1ms);
  }
  const double writeSeconds = since(start);
  // Until the recording holds everything, or it stops growing for 10 s.
  const auto doneWriting = Clock::now();
  std::int64_t recordedLive = eventsIn(file), last = -1;
  auto lastGrowth = Clock::now();
  while (recordedLive < static_cast<std::int64_t>(written) && Clock::now() - lastGrowth < 10s) {
    std::this_thread::sleep_for(100ms);
    recordedLive = eventsIn(file);
    if (recordedLive != last) lastGrowth = Clock::now(), last = recordedLive;
  }
  const double drainSeconds = since(doneWriting);
  ::kill(recorder, SIGINT);
  int status = 0;
  rusage usage{};
  ::wait4(recorder, &status, 0, &usage);
  const double cpu = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                     static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) / 1e6;

  // What reached the file: per key, the seqnos must run 1, 2, 3 ... with no gap.
  std::uint64_t recorded = 0, gaps = 0;
  {
    peis::recorder::Database db(file, peis::recorder::Database::Mode::ReadOnly);
    auto rows = db.prepare("SELECT tuple, seqno FROM events ORDER BY id");
    std::unordered_map<std::int64_t, std::int64_t> lastSeqno;
    while (rows.step()) {
      ++recorded;
      auto& previous = lastSeqno[rows.integer(0)];
      if (rows.integer(1) != previous + 1)
        gaps += static_cast<std::uint64_t>(rows.integer(1) - previous - 1);
      previous = rows.integer(1);
    }
  }
  const auto bytes = std::filesystem::file_size(file);
  std::string summary;
  {
    std::ifstream in(log);
    for (std::string line; std::getline(in, line);) summary = line;
  }
  const auto longest = summary.find("the longest ");
  const double longestCommitMs =
      longest == std::string::npos ? -1 : std::atof(summary.c_str() + longest + 12);
  std::filesystem::remove(log);
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(file + suffix);
  const double updates = static_cast<double>(written);
  // | load | written | achieved /s | recorded | missing | coalesced (seqno gaps / writer) |
  // CPU us per update | CPU % of a core | disk B per update | longest commit | drain s | max RSS |
  std::printf("| %.0f /s x %.0f s, %d keys, 16 B | %" PRIu64 " | %.0f | %" PRIu64 " | %" PRId64
              " | %" PRIu64 " / %" PRIu64 " | %.2f | %.0f %% | %.1f | %.0f ms | %.2f | %ld MiB |\n",
              s.rate, s.seconds, s.keys, written, updates / writeSeconds, recorded,
              static_cast<std::int64_t>(written) - static_cast<std::int64_t>(recorded), gaps,
              writer.networkStats().coalesced, cpu * 1e6 / updates,
              100 * cpu / (writeSeconds + drainSeconds), static_cast<double>(bytes) / updates,
              longestCommitMs, drainSeconds, usage.ru_maxrss / 1024);
  return written == recorded && WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : 1;
}
