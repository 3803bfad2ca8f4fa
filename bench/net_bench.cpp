// peis-bench-net: the ecology over loopback, measured beside a raw TCP
// baseline in the same run. Every peer is a separate process (this program
// re-run with --role). Prints Markdown tables; see docs/performance.md.
#include <arpa/inet.h>
#include <dirent.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <peis/peis.h>
#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "bench_stats.h"
#include "child_process.h"
#include "security/record_cipher.h"

namespace {

using namespace std::chrono_literals;
using peis::bench::Clock;
using peis::bench::nowMicros;
using peis::bench::Percentiles;
using peis::bench::percentiles;

std::string sizeName(std::size_t bytes) {
  return bytes >= 1024 ? std::to_string(bytes / 1024) + " KiB" : std::to_string(bytes) + " B";
}

std::map<std::string, std::string> parseFlags(int argc, char** argv) {
  std::map<std::string, std::string> flags;
  for (int i = 1; i + 1 < argc; i += 2) flags[argv[i]] = argv[i + 1];
  return flags;
}

using peis::bench::Child;

// A PEIS of the benchmark; with `credentials`, of the secured ecology they
// are for (which then names the ecology).
peis::Options hostOptions(const std::string& ecology, int id, bool discovery = false,
                          const std::string& credentials = "") {
  peis::Options options;
  if (credentials.empty()) options.ecology = ecology;
  options.credentials = credentials;
  options.id = id;
  options.name = "bench";
  options.discovery = discovery;
  return options;
}

std::string credentialsFlag(const std::map<std::string, std::string>& flags) {
  const auto it = flags.find("--credentials");
  return it == flags.end() ? std::string() : it->second;
}

bool waitFor(const std::function<bool()>& condition, std::chrono::milliseconds deadline) {
  const auto until = Clock::now() + deadline;
  while (!condition()) {
    if (Clock::now() > until) return false;
    std::this_thread::sleep_for(200us);
  }
  return true;
}

// ---- roles (child processes) ---------------------------------------------------

bool readFully(int fd, char* data, std::size_t n) {
  while (n > 0) {
    const auto got = read(fd, data, n);
    if (got <= 0) return false;
    data += got;
    n -= static_cast<std::size_t>(got);
  }
  return true;
}

int roleTcpEcho() {
  const int server = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(server, reinterpret_cast<sockaddr*>(&address), sizeof address);
  listen(server, 1);
  socklen_t length = sizeof address;
  getsockname(server, reinterpret_cast<sockaddr*>(&address), &length);
  std::printf("%d\n", ntohs(address.sin_port));
  std::fflush(stdout);
  const int client = accept(server, nullptr, nullptr);
  int one = 1;
  setsockopt(client, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  // The length and the payload go back in one write, as they came.
  std::vector<char> buffer((1 << 20) + 4);
  while (true) {
    std::uint32_t size;
    if (!readFully(client, buffer.data(), 4)) break;
    std::memcpy(&size, buffer.data(), 4);
    if (size > (1u << 20) || !readFully(client, buffer.data() + 4, size)) break;
    if (write(client, buffer.data(), size + 4) != static_cast<ssize_t>(size + 4)) break;
  }
  return 0;
}

int rolePeisEcho(const std::map<std::string, std::string>& flags) {
  peis::Options options = hostOptions(flags.at("--ecology"), std::stoi(flags.at("--id")), false,
                                      credentialsFlag(flags));
  options.connect.push_back("127.0.0.1:" + flags.at("--connect"));
  peis::Kernel kernel(options);
  const int peer = std::stoi(flags.at("--peer"));
  kernel.onChange(peis::Pattern::exact(peer, "ping"),
                  [&](const peis::Tuple& t) { kernel.publish("pong", t.data); });
  kernel.subscribe(peis::Pattern::exact(peer, "ping"));
  kernel.run();
  return 0;
}

// Counts the distinct updates of PEER.stream it receives; publishes
// "received" = "count last-seqno first-us last-us" every 10 ms. The time of
// the last delivery is taken by a 1 ms timer that sees the count change (no
// clock read per update; it can only be late, which lowers the rate).
int roleSink(const std::map<std::string, std::string>& flags) {
  peis::Options options = hostOptions(flags.at("--ecology"), std::stoi(flags.at("--id")), false,
                                      credentialsFlag(flags));
  options.connect.push_back("127.0.0.1:" + flags.at("--connect"));
  peis::Kernel kernel(options);
  const int peer = std::stoi(flags.at("--peer"));
  std::uint64_t count = 0, last = 0, countAtTick = 0;
  std::int64_t first = 0, lastAt = 0;
  kernel.onChange(peis::Pattern::exact(peer, "stream"), [&](const peis::Tuple& t) {
    if (t.seqno <= last) return;
    if (count++ == 0) first = nowMicros();
    last = t.seqno;
  });
  kernel.subscribe(peis::Pattern::exact(peer, "stream"));
  auto noteProgress = [&] {
    if (count == countAtTick) return;
    countAtTick = count;
    lastAt = nowMicros();
  };
  kernel.every(1ms, noteProgress);
  kernel.every(10ms, [&] {
    noteProgress();  // what is published never predates the deliveries it counts
    kernel.set("received", std::to_string(count) + " " + std::to_string(last) + " " +
                               std::to_string(first) + " " + std::to_string(lastAt));
  });
  kernel.run();
  return 0;
}

int roleJoin(const std::map<std::string, std::string>& flags) {
  const auto t0 = std::stoll(flags.at("--t0"));
  peis::Kernel kernel(hostOptions(flags.at("--ecology"), std::stoi(flags.at("--id")), true));
  const int peer = std::stoi(flags.at("--peer"));
  auto value = kernel.get(peer, "value", 10s);
  std::printf("%lld\n", value ? static_cast<long long>(nowMicros() - t0) : -1LL);
  return 0;
}

int roleNode(const std::map<std::string, std::string>& flags) {
  peis::Options options = hostOptions(flags.at("--ecology"), std::stoi(flags.at("--id")), true);
  options.setTuples.emplace_back("v", flags.at("--id"));
  peis::Kernel kernel(options);
  std::printf("up\n");
  std::fflush(stdout);
  kernel.run();
  return 0;
}

// ---- measurements (parent) -------------------------------------------------------

Percentiles tcpRoundTrip(std::size_t bytes, int count) {
  Child echo({"--role", "tcp-echo"});
  const int port = std::stoi(echo.line());
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  // One write per message (length and payload together) and 50 warm-up
  // rounds, as the PEIS round trip has: the strongest plain-TCP baseline.
  std::vector<char> message(bytes + 4, 'x');
  const auto size = static_cast<std::uint32_t>(bytes);
  std::memcpy(message.data(), &size, 4);
  std::vector<char> back(bytes + 4);
  std::vector<double> micros;
  for (int i = 0; i < count + 50; ++i) {
    const auto start = Clock::now();
    if (write(fd, message.data(), message.size()) != static_cast<ssize_t>(message.size())) break;
    if (!readFully(fd, back.data(), back.size())) break;
    if (i >= 50)
      micros.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
  }
  close(fd);
  return percentiles(micros);
}

Percentiles peisRoundTrip(std::size_t bytes, int count, const std::string& ecology,
                          const std::string& credentials = "") {
  peis::Kernel kernel(hostOptions(ecology, 1, false, credentials));
  Child echo([&] {
    auto args = std::vector<std::string>{
        "--role", "peis-echo", "--ecology", ecology,     "--id",
        "2",      "--peer",    "1",         "--connect", std::to_string(kernel.port())};
    if (!credentials.empty()) args.insert(args.end(), {"--credentials", credentials});
    return args;
  }());
  kernel.subscribe(peis::Pattern::exact(2, "pong"));
  // Wait until the echo is subscribed to our ping.
  waitFor([&] { return kernel.get(peis::special::kSubscribers)->data == "2"; }, 10s);
  // The writer waits for each pong with the kernel's waitForNext, as an
  // application thread that waits for an answer does (a callback that
  // answers is peisCallbackRoundTrip).
  std::uint64_t seenPong = 0;
  std::vector<double> micros;
  for (int i = 0; i < count + 50; ++i) {
    // Each round's value is made before the clock starts and handed over
    // (publish takes its data by value): as a producer of fresh values
    // (a camera's frames) writes, and as the TCP baseline writes its
    // message from where it is, without copying it first.
    std::string payload(bytes, 'x');
    char tag[17];
    std::snprintf(tag, sizeof tag, "%016d", i);
    std::memcpy(payload.data(), tag, std::min<std::size_t>(16, bytes));
    const std::string expect = payload.substr(0, 16);
    const auto start = Clock::now();
    kernel.publish("ping", std::move(payload));
    std::shared_ptr<const peis::Tuple> pong;
    while ((pong = kernel.waitForNext(2, "pong", seenPong, 5s)) &&
           pong->data.compare(0, 16, expect) != 0) {
      seenPong = pong->seqno;  // an earlier round's (none is expected)
    }
    if (!pong) break;
    seenPong = pong->seqno;
    if (i >= 50)
      micros.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
  }
  // Ended with SIGTERM (the echo's run() returns and it exits): a profiler
  // following the echo (valgrind --trace-children) then writes its figures.
  echo.stop();
  if (micros.empty()) return {-1, -1, -1};
  return percentiles(micros);
}

// The same round trip as an application written in callbacks measures it
// (as the echo answers): the next ping is published from the pong's
// callback, on the kernel thread that read the pong, and no other thread is
// woken per round. Beside peisRoundTrip, it shows what waking the waiting
// application thread costs (docs/performance.md, "The round trip at 64 KiB").
Percentiles peisCallbackRoundTrip(std::size_t bytes, int count, const std::string& ecology) {
  std::mutex mu;
  std::condition_variable cv;
  bool finished = false;
  std::vector<double> micros;
  micros.reserve(static_cast<std::size_t>(count));
  int round = 0;
  std::string expect;
  Clock::time_point start;
  peis::Kernel kernel(hostOptions(ecology, 1, false));
  Child echo({"--role", "peis-echo", "--ecology", ecology, "--id", "2", "--peer", "1", "--connect",
              std::to_string(kernel.port())});
  // Made before the clock starts, as in peisRoundTrip.
  auto ping = [&] {
    std::string payload(bytes, 'x');
    char tag[17];
    std::snprintf(tag, sizeof tag, "%016d", round);
    std::memcpy(payload.data(), tag, std::min<std::size_t>(16, bytes));
    expect = payload.substr(0, 16);
    start = Clock::now();
    kernel.publish("ping", std::move(payload));
  };
  kernel.onChange(peis::Pattern::exact(2, "pong"), [&](const peis::Tuple& t) {
    if (round > count + 50 || t.data.compare(0, 16, expect) != 0) return;
    const auto end = Clock::now();
    if (round >= 50)
      micros.push_back(std::chrono::duration<double, std::micro>(end - start).count());
    if (++round < count + 50) return ping();
    std::lock_guard lock(mu);
    finished = true;
    cv.notify_one();
  });
  kernel.subscribe(peis::Pattern::exact(2, "pong"));
  waitFor([&] { return kernel.get(peis::special::kSubscribers)->data == "2"; }, 10s);
  kernel.post(ping);
  {
    std::unique_lock lock(mu);
    cv.wait_for(lock, 5s + count * 10ms, [&] { return finished; });
  }
  // The measurements are the kernel thread's until it is stopped.
  std::vector<double> taken;
  std::promise<void> stopped;
  kernel.post([&] {
    round = count + 51;
    taken = std::move(micros);
    stopped.set_value();
  });
  stopped.get_future().wait();
  echo.stop();
  if (taken.size() < static_cast<std::size_t>(count)) return {-1, -1, -1};
  return percentiles(taken);
}

struct Throughput {
  double updatesPerSecond = 0;
  double megabytesPerSecond = 0;
  std::uint64_t delivered = 0, written = 0, coalesced = 0;
};

Throughput streamTo(std::size_t bytes, int sinks, const std::string& ecology,
                    std::chrono::milliseconds writeFor, const std::string& credentials = "") {
  peis::Kernel kernel(hostOptions(ecology, 1, false, credentials));
  std::vector<std::unique_ptr<Child>> children;
  for (int i = 0; i < sinks; ++i) {
    std::vector<std::string> args{"--role",    "sink",
                                  "--ecology", ecology,
                                  "--id",      std::to_string(100 + i),
                                  "--peer",    "1",
                                  "--connect", std::to_string(kernel.port())};
    if (!credentials.empty()) args.insert(args.end(), {"--credentials", credentials});
    children.push_back(std::make_unique<Child>(args));
  }
  for (int i = 0; i < sinks; ++i) kernel.subscribe(peis::Pattern::exact(100 + i, "received"));
  waitFor(
      [&] {
        auto s = kernel.get(peis::special::kSubscribers);
        return s && std::count(s->data.begin(), s->data.end(), ' ') + 1 >= sinks &&
               !s->data.empty();
      },
      20s);
  const std::string payload(bytes, 'x');
  // PEIS_BENCH_STREAM_UPDATES=N writes N updates (a multiple of 64) instead
  // of writing for `writeFor`: a fixed amount of work, for CPU time and
  // instruction counts per update (docs/performance.md, "Method").
  const char* fixed = std::getenv("PEIS_BENCH_STREAM_UPDATES");
  const std::uint64_t updates = fixed ? std::strtoull(fixed, nullptr, 10) : 0;
  const auto start = nowMicros();
  const auto until = Clock::now() + writeFor;
  std::uint64_t written = 0, last = 0;
  while (updates > 0 ? written < updates : Clock::now() < until) {
    for (int i = 0; i < 64; ++i) last = kernel.publish("stream", payload);
    written += 64;
  }
  Throughput result;
  result.written = written;
  std::int64_t lastAt = 0;
  waitFor(
      [&] {
        std::uint64_t delivered = 0;
        std::int64_t latest = 0;
        for (int i = 0; i < sinks; ++i) {
          auto r = kernel.get(100 + i, "received");
          if (!r) return false;
          unsigned long long count = 0, seqno = 0;
          long long first = 0, at = 0;
          std::sscanf(r->data.c_str(), "%llu %llu %lld %lld", &count, &seqno, &first, &at);
          if (seqno != last) return false;
          delivered += count;
          latest = std::max<std::int64_t>(latest, at);
        }
        result.delivered = delivered;
        lastAt = latest;
        return true;
      },
      60s);
  const double seconds = static_cast<double>(lastAt - start) / 1e6;
  if (seconds > 0) {
    result.updatesPerSecond = static_cast<double>(result.delivered) / seconds;
    result.megabytesPerSecond = result.updatesPerSecond * static_cast<double>(bytes) / 1e6;
  }
  result.coalesced = kernel.networkStats().coalesced;
  // Asked to quit (SIGTERM) rather than killed: a sink profiled under
  // valgrind writes its profile as it exits.
  for (auto& child : children) child->stop();
  return result;
}

double joinMillis(const std::string& ecology) {
  peis::Kernel kernel(hostOptions(ecology, 1, true));
  kernel.set("value", "42");
  std::vector<double> samples;
  for (int i = 0; i < 5; ++i) {
    const auto t0 = nowMicros();
    Child joiner({"--role", "join", "--ecology", ecology, "--id", std::to_string(500 + i), "--peer",
                  "1", "--t0", std::to_string(t0)});
    const auto micros = std::stoll(joiner.line());
    if (micros >= 0) samples.push_back(static_cast<double>(micros) / 1000.0);
  }
  if (samples.empty()) return -1;
  return percentiles(samples).p50;
}

struct ScaleResult {
  double secondsToAll = -1;
  double idleCpuPercent = -1;
  double rssKib = -1;
  double pssKib = -1;      // shared library pages divided among the processes
  double privateKib = -1;  // pages only this process uses
};

// The /proc files are read with stdio: every PEIS of the scale run is this
// program, and iostreams would link libstdc++'s locale code into it, whose
// pages each PEIS would map (docs/performance.md, "Memory per PEIS").
std::string procText(pid_t pid, const char* file) {
  std::string text;
  std::FILE* in = std::fopen(("/proc/" + std::to_string(pid) + "/" + file).c_str(), "r");
  if (in == nullptr) return text;
  char chunk[4096];
  std::size_t n = 0;
  while ((n = std::fread(chunk, 1, sizeof chunk, in)) > 0) text.append(chunk, n);
  std::fclose(in);
  return text;
}

long procTicks(pid_t pid) {
  const auto text = procText(pid, "stat");
  const auto close = text.rfind(')');
  if (close == std::string::npos) return 0;
  // Fields 14 and 15 (utime, stime); field 3 follows the ") ".
  unsigned long utime = 0, stime = 0;
  if (std::sscanf(text.c_str() + close + 1, " %*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu",
                  &utime, &stime) != 2) {
    return 0;
  }
  return static_cast<long>(utime + stime);
}

// The CPU time of every thread of a process, in seconds, from schedstat (in
// ns, where the clock ticks of /proc/PID/stat lose up to 20 ms a process).
double procCpuSeconds(pid_t pid) {
  double total = 0;
  const std::string dir = "/proc/" + std::to_string(pid) + "/task";
  if (DIR* tasks = opendir(dir.c_str())) {
    while (dirent* task = readdir(tasks)) {
      if (task->d_name[0] == '.') continue;
      std::FILE* in = std::fopen((dir + "/" + task->d_name + "/schedstat").c_str(), "r");
      if (in == nullptr) continue;
      unsigned long long ns = 0;
      if (std::fscanf(in, "%llu", &ns) == 1) total += static_cast<double>(ns) / 1e9;
      std::fclose(in);
    }
    closedir(tasks);
  }
  return total;
}

// A "Name:   123 kB" field of a /proc file, in KiB (0 if absent).
long procKib(pid_t pid, const char* file, const std::string& field) {
  const auto text = procText(pid, file);
  for (std::size_t at = 0; at < text.size();) {
    const auto end = std::min(text.find('\n', at), text.size());
    if (text.compare(at, field.size(), field) == 0) {
      return std::strtol(text.c_str() + at + field.size(), nullptr, 10);
    }
    at = end + 1;
  }
  return 0;
}

ScaleResult scale(int n, const std::string& ecology) {
  ScaleResult result;
  const auto start = Clock::now();
  std::vector<std::unique_ptr<Child>> nodes;
  for (int i = 0; i < n; ++i) {
    nodes.push_back(std::make_unique<Child>(std::vector<std::string>{
        "--role", "node", "--ecology", ecology, "--id", std::to_string(1000 + i)}));
  }
  // PEIS_BENCH_PROGRESS=1: how many values (and peers) were seen when, to stderr.
  const bool progress = std::getenv("PEIS_BENCH_PROGRESS") != nullptr;
  if (progress) {
    std::fprintf(stderr, "scale %d: %.2f s: %d processes started\n", n,
                 std::chrono::duration<double>(Clock::now() - start).count(), n);
  }
  peis::Kernel kernel(hostOptions(ecology, 1, true));
  kernel.subscribe(peis::Pattern("v"));
  if (progress) {
    std::fprintf(stderr, "scale %d: %.2f s: the subscriber started\n", n,
                 std::chrono::duration<double>(Clock::now() - start).count());
  }
  auto lastReport = Clock::now();
  const bool all = waitFor(
      [&] {
        const auto seen = kernel.find(peis::Pattern("v")).size();
        if (progress && Clock::now() - lastReport >= 250ms) {
          lastReport = Clock::now();
          double cpu = 0;
          for (auto& node : nodes) cpu += procCpuSeconds(node->pid());
          std::fprintf(stderr,
                       "scale %d: %.2f s: %zu values, %zu peers, CPU of the nodes %.2f s, of the "
                       "subscriber %.2f s\n",
                       n, std::chrono::duration<double>(lastReport - start).count(), seen,
                       kernel.peers().size(), cpu, procCpuSeconds(getpid()));
        }
        return seen >= static_cast<std::size_t>(n);
      },
      60s);
  if (all) result.secondsToAll = std::chrono::duration<double>(Clock::now() - start).count();
  if (progress) {
    // The CPU the nodes spent until then: far less sensitive to the load of
    // the machine than the time (docs/performance.md, "Scale").
    // From schedstat: the clock ticks of /proc/PID/stat, truncated per
    // process, left out about 1.5 s of 200 processes' CPU (the figures
    // before 2026-11-29); they are printed beside it for comparison.
    long ticks = 0;
    double exact = 0;
    for (auto& node : nodes) {
      ticks += procTicks(node->pid());
      exact += procCpuSeconds(node->pid());
    }
    std::fprintf(stderr,
                 "scale %d: %.2f s: all %s, CPU of the nodes until then %.2f s (clock ticks: "
                 "%.2f s)\n",
                 n, std::chrono::duration<double>(Clock::now() - start).count(),
                 all ? "values seen" : "values NOT seen", exact,
                 static_cast<double>(ticks) / static_cast<double>(sysconf(_SC_CLK_TCK)));
  }
  std::this_thread::sleep_for(4s);  // let start-up work (and link pruning) finish first
  std::vector<long> before;
  for (auto& node : nodes) before.push_back(procTicks(node->pid()));
  const auto window = 5s;
  std::this_thread::sleep_for(window);
  double ticks = 0, rss = 0, pss = 0, own = 0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const auto pid = nodes[i]->pid();
    ticks += static_cast<double>(procTicks(pid) - before[i]);
    rss += static_cast<double>(procKib(pid, "status", "VmRSS:"));
    pss += static_cast<double>(procKib(pid, "smaps_rollup", "Pss:"));
    own += static_cast<double>(procKib(pid, "smaps_rollup", "Private_Clean:") +
                               procKib(pid, "smaps_rollup", "Private_Dirty:"));
  }
  const double hz = static_cast<double>(sysconf(_SC_CLK_TCK));
  result.idleCpuPercent = ticks / hz / 5.0 / n * 100.0;
  result.rssKib = rss / n;
  result.pssKib = pss / n;
  result.privateKib = own / n;
  return result;
}

// The time from starting a PEIS that dials a running one to the link being
// established at both ends (in this process), p50 of `rounds`: with
// credentials, the secured handshake (key exchange, certificates,
// signatures) is in it.
double linkSetupMillis(const std::string& ecology, const std::string& credentials, int rounds) {
  peis::Kernel server(hostOptions(ecology, 1, false, credentials));
  std::vector<double> millis;
  for (int i = 0; i < rounds; ++i) {
    auto options = hostOptions(ecology, 2 + i, false, credentials);
    options.connect.push_back("127.0.0.1:" + std::to_string(server.port()));
    const auto start = Clock::now();
    peis::Kernel client(options);
    const bool linked = waitFor(
        [&] {
          bool both = false;
          for (const auto& p : server.peers()) both |= p.id == 2 + i;
          if (!both) return false;
          for (const auto& p : client.peers()) {
            if (p.id == 1) return true;
          }
          return false;
        },
        10s);
    if (linked) {
      millis.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
  }
  if (millis.empty()) return -1;
  std::sort(millis.begin(), millis.end());
  return millis[millis.size() / 2];
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values.empty() ? -1 : values[values.size() / 2];
}

// Open beside secured, in the same run and interleaved (open, secured,
// open, ...), medians of `reps`: round trip, throughput, the handshake.
void securityComparison(const std::string& ecology) {
  const std::string dir = "/tmp/peis-bench-keys-" + std::to_string(getpid());
  const std::string secured = "bench-secured-" + std::to_string(getpid());
  peis::createTrustRoot(dir, secured);
  peis::CredentialsRequest request;
  request.principal = "bench";
  request.names = {"*"};
  const auto credentials = peis::issueCredentials(dir, request).file;
  std::printf("| security | size | open | secured | secured / open |\n|---|---|---|---|---|\n");
  const int reps = 3;
  for (std::size_t bytes : {16u, 1024u, 65536u}) {
    const int count = bytes >= 65536 ? 500 : 2000;
    std::vector<double> open, closed;
    for (int r = 0; r < reps; ++r) {
      open.push_back(peisRoundTrip(bytes, count, ecology + "-srtt").p50);
      closed.push_back(peisRoundTrip(bytes, count, secured, credentials).p50);
    }
    std::printf("| round trip p50 (us) | %s | %.1f | %.1f | %.2fx |\n", sizeName(bytes).c_str(),
                median(open), median(closed), median(closed) / median(open));
    std::fflush(stdout);
  }
  for (std::size_t bytes : {16u, 1024u, 65536u}) {
    std::vector<double> open, closed;
    for (int r = 0; r < reps; ++r) {
      open.push_back(streamTo(bytes, 1, ecology + "-stp", 2s).updatesPerSecond);
      closed.push_back(streamTo(bytes, 1, secured, 2s, credentials).updatesPerSecond);
    }
    std::printf("| throughput (updates/s) | %s | %.0f | %.0f | %.2fx |\n", sizeName(bytes).c_str(),
                median(open), median(closed), median(closed) / median(open));
    std::fflush(stdout);
  }
  const auto openSetup = linkSetupMillis(ecology + "-hs", "", 21);
  const auto securedSetup = linkSetupMillis(secured, credentials, 21);
  std::printf("| link set-up, start to linked (ms, p50 of 21) | - | %.2f | %.2f | %.2fx |\n\n",
              openSetup, securedSetup, securedSetup / openSetup);
  std::printf(
      "The secured links' records: AES-256-GCM by %s (the faster on this CPU).\n\n",
      peis::security::RecordCipher::implementation(peis::security::CipherSuite::Aes256Gcm).c_str());
  std::fflush(stdout);
  std::filesystem::remove_all(dir);
}

// `sizes` ("16,1024"; empty: all) limits the throughput runs (and for scale, the N), for
// profiling.
int runAll(const std::string& what, const std::string& sizes) {
  const std::string ecology = "bench-" + std::to_string(getpid());
  auto wanted = [&](const char* name) { return what == "all" || what == name; };
  if (wanted("rtt")) {
    std::printf(
        "| round trip | size | raw TCP p50 / p90 / p99 (us) | PEIS p50 / p90 / p99 (us) | PEIS / "
        "TCP p50 |\n|---|---|---|---|---|\n");
    for (std::size_t bytes : {16u, 1024u, 65536u}) {
      const int count = bytes >= 65536 ? 500 : 2000;
      const auto tcp = tcpRoundTrip(bytes, count);
      const auto peis = peisRoundTrip(bytes, count, ecology + "-rtt" + std::to_string(bytes));
      std::printf("| one hop | %s | %.1f / %.1f / %.1f | %.1f / %.1f / %.1f | %.2fx |\n",
                  sizeName(bytes).c_str(), tcp.p50, tcp.p90, tcp.p99, peis.p50, peis.p90, peis.p99,
                  peis.p50 / tcp.p50);
      std::fflush(stdout);
    }
    std::printf("\n");
  }
  if (wanted("throughput")) {
    std::printf(
        "| stream | size | subscribers | written | delivered (distinct) | updates/s delivered | "
        "MB/s | coalesced |\n|---|---|---|---|---|---|---|---|\n");
    for (std::size_t bytes : {16u, 1024u, 65536u}) {
      if (!sizes.empty() &&
          ("," + sizes + ",").find("," + std::to_string(bytes) + ",") == std::string::npos) {
        continue;
      }
      const auto r = streamTo(bytes, 1, ecology + "-tp" + std::to_string(bytes), 2s);
      std::printf("| one writer | %s | 1 | %llu | %llu | %.0f | %.1f | %llu |\n",
                  sizeName(bytes).c_str(), static_cast<unsigned long long>(r.written),
                  static_cast<unsigned long long>(r.delivered), r.updatesPerSecond,
                  r.megabytesPerSecond, static_cast<unsigned long long>(r.coalesced));
      std::fflush(stdout);
    }
    if (!sizes.empty()) return 0;
    const auto r = streamTo(16, 10, ecology + "-fan", 2s);
    std::printf("| fan-out | 16 B | 10 | %llu | %llu | %.0f | %.1f | %llu |\n\n",
                static_cast<unsigned long long>(r.written),
                static_cast<unsigned long long>(r.delivered), r.updatesPerSecond,
                r.megabytesPerSecond, static_cast<unsigned long long>(r.coalesced));
    std::fflush(stdout);
  }
  if (wanted("security")) securityComparison(ecology);
  if (wanted("join")) {
    std::printf(
        "| join | p50 of 5 (ms) |\n|---|---|\n| new PEIS process start -> first value of a "
        "subscribed tuple | %.1f |\n\n",
        joinMillis(ecology + "-join"));
    std::fflush(stdout);
  }
  if (wanted("scale")) {
    std::printf(
        "| scale | N | all N values seen (s) | idle CPU per PEIS (%%) | RSS per PEIS (KiB) "
        "| PSS (KiB) | private (KiB) |\n|---|---|---|---|---|---|---|\n");
    for (int n : {10, 50, 200}) {
      if (!sizes.empty() &&
          ("," + sizes + ",").find("," + std::to_string(n) + ",") == std::string::npos) {
        continue;
      }
      const auto r = scale(n, ecology + "-scale" + std::to_string(n));
      std::printf("| processes on one host | %d | %.2f | %.3f | %.0f | %.0f | %.0f |\n", n,
                  r.secondsToAll, r.idleCpuPercent, r.rssKib, r.pssKib, r.privateKib);
      std::fflush(stdout);
    }
    std::printf("\n");
  }
  return 0;
}

// One measurement as one line of numbers, for the side-by-side comparison
// (bench/run_peer_comparison.sh), which interleaves the systems and takes
// medians over repetitions:
//   tcp-rtt SIZE, peis-rtt[-secured] SIZE -> p50 p90 p99 (us); PEIS_BENCH_ROUNDS=N for N rounds
//   peis-rtt-callback SIZE        -> the same, answered in the callback (peisCallbackRoundTrip)
//   peis-stream[-secured] SIZE    -> delivered/s delivered written coalesced
// (`-secured`: in a secured ecology of fresh credentials)
//   scale N                       -> seconds-to-all idle-cpu-% rss pss private (KiB)
int runOnce(const std::string& kind, const std::string& argument) {
  const std::string ecology = "bench-" + std::to_string(getpid());
  const auto value = std::stoul(argument);
  // A secured ecology's credentials for the `-secured` kinds, removed on return.
  const bool secured = kind.size() > 8 && kind.substr(kind.size() - 8) == "-secured";
  const std::string dir = "/tmp/peis-bench-keys-" + std::to_string(getpid());
  std::string credentials;
  if (secured) {
    peis::createTrustRoot(dir, ecology + "-sec");
    peis::CredentialsRequest request;
    request.principal = "bench";
    request.names = {"*"};
    credentials = peis::issueCredentials(dir, request).file;
  }
  struct RemoveKeys {
    const std::string& dir;
    bool secured;
    ~RemoveKeys() {
      if (secured) std::filesystem::remove_all(dir);
    }
  } removeKeys{dir, secured};
  if (kind == "peis-rtt-callback") {
    const char* rounds = std::getenv("PEIS_BENCH_ROUNDS");
    const int count = rounds ? std::atoi(rounds) : value >= 65536 ? 500 : 2000;
    const auto p = peisCallbackRoundTrip(value, count, ecology + "-crtt");
    std::printf("%.2f %.2f %.2f\n", p.p50, p.p90, p.p99);
    return p.p50 > 0 ? 0 : 1;
  }
  if (kind == "tcp-rtt" || kind == "peis-rtt" || kind == "peis-rtt-secured") {
    // PEIS_BENCH_ROUNDS: another number of round trips (CPU time per round
    // trip is the difference of two runs of different lengths).
    const char* rounds = std::getenv("PEIS_BENCH_ROUNDS");
    const int count = rounds ? std::atoi(rounds) : value >= 65536 ? 500 : 2000;
    const auto p = kind == "tcp-rtt" ? tcpRoundTrip(value, count)
                                     : peisRoundTrip(value, count, ecology + "-rtt", credentials);
    std::printf("%.2f %.2f %.2f\n", p.p50, p.p90, p.p99);
    return p.p50 > 0 ? 0 : 1;
  }
  if (kind == "peis-stream" || kind == "peis-stream-secured") {
    const auto r = streamTo(value, 1, ecology + "-tp", 2s, credentials);
    std::printf(
        "%.0f %llu %llu %llu\n", r.updatesPerSecond, static_cast<unsigned long long>(r.delivered),
        static_cast<unsigned long long>(r.written), static_cast<unsigned long long>(r.coalesced));
    return r.updatesPerSecond > 0 ? 0 : 1;
  }
  if (kind == "scale") {
    const auto r = scale(static_cast<int>(value), ecology + "-scale");
    std::printf("%.3f %.4f %.0f %.0f %.0f\n", r.secondsToAll, r.idleCpuPercent, r.rssKib, r.pssKib,
                r.privateKib);
    return r.secondsToAll > 0 ? 0 : 1;
  }
  std::fprintf(stderr, "peis-bench-net once: unknown measurement '%s'\n", kind.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && (std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0)) {
    std::printf(
        "Usage: peis-bench-net [all|rtt|throughput|security|join|scale] [SIZES]\n"
        "       peis-bench-net once "
        "tcp-rtt|peis-rtt[-secured]|peis-rtt-callback|peis-stream[-secured] "
        "SIZE\n"
        "       peis-bench-net once scale N\n"
        "SIZES (e.g. 16,1024) limits the one-writer throughput runs to those sizes,\n"
        "and for scale (e.g. 200) the numbers of processes.\n"
        "Measures the ecology over loopback beside raw TCP; prints Markdown tables.\n"
        "`security` measures a secured ecology beside an open one in the same run.\n"
        "`once` prints one measurement as a line of numbers (see run_peer_comparison.sh).\n");
    return 0;
  }
  if (argc > 2 && std::strcmp(argv[1], "--role") == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive the benchmark
    if (getppid() == 1) return 1;      // it is gone already
    const std::string role = argv[2];
    const auto flags = parseFlags(argc - 2, argv + 2);
    if (role == "tcp-echo") return roleTcpEcho();
    if (role == "peis-echo") return rolePeisEcho(flags);
    if (role == "sink") return roleSink(flags);
    if (role == "join") return roleJoin(flags);
    if (role == "node") return roleNode(flags);
    return 2;
  }
  if (argc == 4 && std::strcmp(argv[1], "once") == 0) return runOnce(argv[2], argv[3]);
  return runAll(argc > 1 ? argv[1] : "all", argc > 2 ? argv[2] : "");
}
