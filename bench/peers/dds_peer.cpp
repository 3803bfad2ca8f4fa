// Cyclone DDS as a benchmark peer, through its C API: a ping-pong between two
// processes with a listener answering on Cyclone's receive thread, and a
// one-way stream to one reader. Loopback only, multicast off, on a domain of
// its own per run, so it never leaves this host nor meets other runs.
#include <dds/dds.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "../child_process.h"
#include "bench_message.h"
#include "peers.h"

namespace peis::bench {
namespace {

using namespace std::chrono_literals;

constexpr std::uint64_t kStop = ~0ull;

void configureLoopbackOnly() {
  setenv("CYCLONEDDS_URI",
         "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"lo\"/>"
         "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
         "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20"
         "</MaxAutoParticipantIndex><Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery>"
         "</Domain></CycloneDDS>",
         1);
}

int domainOfThisRun() { return 1 + static_cast<int>(getpid() % 200); }

dds_qos_t* qosFor(bool keepAll) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  if (keepAll) {  // with ddsperf's generous resource limits
    dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
    dds_qset_resource_limits(qos, 10000, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
  } else {
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
  }
  return qos;
}

// One participant with the entities of one side of a measurement.
struct Side {
  dds_entity_t participant = 0;
  explicit Side(int domain) {
    participant = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    if (participant < 0) {
      std::fprintf(stderr, "dds: cannot create a participant: %s\n", dds_strretcode(participant));
      std::exit(1);
    }
  }
  ~Side() { dds_delete(participant); }
  dds_entity_t topic(const char* name) {
    return dds_create_topic(participant, &PeisBench_Message_desc, name, nullptr, nullptr);
  }
  dds_entity_t writer(const char* name, bool keepAll) {
    dds_qos_t* qos = qosFor(keepAll);
    const auto w = dds_create_writer(participant, topic(name), qos, nullptr);
    dds_delete_qos(qos);
    return w;
  }
  dds_entity_t reader(const char* name, bool keepAll, dds_on_data_available_fn onData, void* arg) {
    dds_qos_t* qos = qosFor(keepAll);
    dds_listener_t* listener = dds_create_listener(arg);
    dds_lset_data_available(listener, onData);
    const auto r = dds_create_reader(participant, topic(name), qos, listener);
    dds_delete_listener(listener);
    dds_delete_qos(qos);
    return r;
  }
};

// Calls visit(sample) for every valid sample waiting on the reader (loaned).
template <typename Visit>
void takeAll(dds_entity_t reader, Visit visit) {
  void* samples[16] = {};
  dds_sample_info_t infos[16];
  while (true) {
    const int n = dds_take(reader, samples, infos, 16, 16);
    if (n <= 0) return;
    for (int i = 0; i < n; ++i) {
      if (infos[i].valid_data) visit(*static_cast<PeisBench_Message*>(samples[i]));
    }
    dds_return_loan(reader, samples, n);
  }
}

bool waitMatched(dds_entity_t writer, std::chrono::seconds deadline) {
  const auto until = Clock::now() + deadline;
  while (Clock::now() < until) {
    dds_publication_matched_status_t status;
    if (dds_get_publication_matched_status(writer, &status) == 0 && status.current_count > 0)
      return true;
    std::this_thread::sleep_for(1ms);
  }
  return false;
}

struct Echo {
  dds_entity_t pong = 0;
};

void echoBack(dds_entity_t reader, void* arg) {
  auto* echo = static_cast<Echo*>(arg);
  takeAll(reader, [&](const PeisBench_Message& m) { dds_write(echo->pong, &m); });
}

struct Awaited {
  std::mutex mu;
  std::condition_variable cv;
  std::uint64_t last = kStop;
};

void notePong(dds_entity_t reader, void* arg) {
  auto* awaited = static_cast<Awaited*>(arg);
  takeAll(reader, [&](const PeisBench_Message& m) {
    std::lock_guard lock(awaited->mu);
    awaited->last = m.seqno;
    awaited->cv.notify_one();
  });
}

struct Sink {
  std::mutex mu;
  std::condition_variable cv;
  std::uint64_t count = 0, last = 0;
  std::int64_t lastAt = 0;
  bool stopped = false;
};

void countSample(dds_entity_t reader, void* arg) {
  auto* sink = static_cast<Sink*>(arg);
  takeAll(reader, [&](const PeisBench_Message& m) {
    if (m.seqno == kStop) {
      std::lock_guard lock(sink->mu);
      sink->stopped = true;
      sink->cv.notify_one();
    } else if (m.seqno > sink->last) {
      sink->last = m.seqno;
      ++sink->count;
      sink->lastAt = nowMicros();
    }
  });
}

PeisBench_Message messageOf(std::vector<std::uint8_t>& payload) {
  PeisBench_Message m{};
  m.data._buffer = payload.data();
  m.data._length = m.data._maximum = static_cast<std::uint32_t>(payload.size());
  m.data._release = false;
  return m;
}

}  // namespace

int ddsEchoRole(int domain) {
  Side side(domain);
  Echo echo;
  echo.pong = side.writer("pong", false);
  side.reader("ping", false, echoBack, &echo);
  std::printf("ready\n");
  std::fflush(stdout);
  while (true) pause();
}

int ddsSinkRole(int domain) {
  Side side(domain);
  Sink sink;
  side.reader("stream", true, countSample, &sink);
  std::printf("ready\n");
  std::fflush(stdout);
  std::unique_lock lock(sink.mu);
  sink.cv.wait(lock, [&] { return sink.stopped; });
  std::printf("%llu %lld\n", static_cast<unsigned long long>(sink.count),
              static_cast<long long>(sink.lastAt));
  std::fflush(stdout);
  return 0;
}

Percentiles ddsRoundTrip(std::size_t bytes, int count) {
  configureLoopbackOnly();
  const int domain = domainOfThisRun();
  Child echo({"--role", "dds-echo", "--domain", std::to_string(domain)});
  if (echo.line() != "ready") return {};
  Side side(domain);
  Awaited awaited;
  const auto ping = side.writer("ping", false);
  side.reader("pong", false, notePong, &awaited);
  if (!waitMatched(ping, 10s)) return {};
  std::vector<std::uint8_t> payload(bytes, 'x');
  auto message = messageOf(payload);
  std::vector<double> micros;
  // The first rounds are repeated until answered: the echo's writer may not
  // have matched our reader yet (volatile data is not kept for late readers).
  for (int i = 0; i < count + 50; ++i) {
    message.seqno = static_cast<std::uint64_t>(i);
    const auto start = Clock::now();
    const auto giveUp = start + 10s;
    bool answered = false;
    while (!answered && Clock::now() < giveUp) {
      dds_write(ping, &message);
      std::unique_lock lock(awaited.mu);
      answered = awaited.cv.wait_for(lock, i < 50 ? 200ms : 10s,
                                     [&] { return awaited.last == message.seqno; });
    }
    if (!answered) return {};
    if (i >= 50) micros.push_back(microsSince(start));
  }
  return percentiles(micros);
}

StreamResult ddsStream(std::size_t bytes, double seconds) {
  configureLoopbackOnly();
  const int domain = domainOfThisRun();
  Child sink({"--role", "dds-sink", "--domain", std::to_string(domain)});
  if (sink.line() != "ready") return {};
  Side side(domain);
  // Small samples packed into fewer packets, as ddsperf publishes (set once
  // the domain exists: it applies to the domains there are); the stop sample
  // is flushed.
  dds_write_set_batch(true);
  const auto writer = side.writer("stream", true);
  if (!waitMatched(writer, 10s)) return {};
  std::this_thread::sleep_for(100ms);  // let discovery finish on both sides
  std::vector<std::uint8_t> payload(bytes, 'x');
  auto message = messageOf(payload);
  StreamResult result;
  const auto start = nowMicros();
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  std::uint64_t seqno = 0;
  while (Clock::now() < until) {
    for (int i = 0; i < 64; ++i) {
      message.seqno = ++seqno;
      while (dds_write(writer, &message) != DDS_RETCODE_OK) {
      }
    }
  }
  result.written = seqno;
  message.seqno = kStop;
  dds_write(writer, &message);
  dds_write_flush(writer);
  unsigned long long delivered = 0;
  long long lastAt = 0;
  if (std::sscanf(sink.line().c_str(), "%llu %lld", &delivered, &lastAt) != 2) return result;
  result.delivered = delivered;
  if (lastAt > start)
    result.deliveredPerSecond =
        static_cast<double>(delivered) / (static_cast<double>(lastAt - start) / 1e6);
  return result;
}

}  // namespace peis::bench
