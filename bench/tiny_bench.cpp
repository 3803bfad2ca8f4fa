// Benchmark of the tinybridge (./run bench; table in docs/performance.md):
//
//   peis-bench-tiny roundtrip --link LINK [--rounds N] [--label TEXT] -- NODE_COMMAND...
//     The round trip full PEIS -> bridge -> tiny node -> back: this process
//     is full PEIS 6890 and sets LightValue; the lamp node (NODE_COMMAND:
//     the host-port program on the medium, or firmware under an emulator)
//     gets it through the bridge, sets its LampLevel, and the bridge
//     mirrors that back into the ecology, where this process sees it.
//     With a medium link a sniffer on the medium counts the frames and
//     bytes on the air per round trip. Beside it, in the same run, the
//     baseline of the medium itself: a UDP ping-pong on 127.0.0.1.
//   peis-bench-tiny frames
//     Radio-frame efficiency: useful data bytes per frame for tuples of
//     one sub-key and 1..68 data bytes, from the real encoder.
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "host_medium.h"
#include "peis/kernel.h"
#include "tiny_tuple.h"

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

// A child process (the bridge, the node), killed by pid at the end.
class Child {
 public:
  // quiet: stdout to /dev/null (the node's reports).
  Child(std::vector<std::string> argv, const std::vector<std::string>& env, bool quiet = false) {
    pid_ = fork();
    if (pid_ == 0) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (quiet) {
        const int null = open("/dev/null", O_WRONLY);
        if (null >= 0) dup2(null, 1);
      }
      for (const auto& e : env) putenv(const_cast<char*>(e.c_str()));
      std::vector<char*> args;
      for (auto& a : argv) args.push_back(a.data());
      args.push_back(nullptr);
      execvp(args[0], args.data());
      std::fprintf(stderr, "peis-bench-tiny: cannot run %s: %s\n", args[0], std::strerror(errno));
      _exit(127);
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      for (int i = 0; i < 200; ++i) {
        if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
        usleep(5000);
      }
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }

 private:
  pid_t pid_ = -1;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

std::string us(double value) {
  char text[32];
  std::snprintf(text, sizeof text, value >= 1000 ? "%.2f ms" : "%.1f us",
                value >= 1000 ? value / 1000 : value);
  return text;
}

// The medium's own round trip: a UDP ping-pong between two sockets.
std::vector<double> udpBaseline(int rounds) {
  int a = socket(AF_INET, SOCK_DGRAM, 0), b = socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  bind(b, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  getsockname(b, reinterpret_cast<sockaddr*>(&addr), &len);
  sockaddr_in aaddr{};
  aaddr.sin_family = AF_INET;
  aaddr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(a, reinterpret_cast<sockaddr*>(&aaddr), sizeof aaddr);
  len = sizeof aaddr;
  getsockname(a, reinterpret_cast<sockaddr*>(&aaddr), &len);
  std::vector<double> out;
  char buf[TINY_FRAME_MAX] = {};
  for (int i = 0; i < rounds; ++i) {
    const auto t0 = Clock::now();
    sendto(a, buf, 35, 0, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    recv(b, buf, sizeof buf, 0);
    sendto(b, buf, 35, 0, reinterpret_cast<sockaddr*>(&aaddr), sizeof aaddr);
    recv(a, buf, sizeof buf, 0);
    out.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  close(a);
  close(b);
  return out;
}

int roundtrip(int argc, char** argv) {
  std::string link, label = "host port";
  int rounds = 200;
  std::vector<std::string> node;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") {
      for (++i; i < argc; ++i) node.push_back(argv[i]);
    } else if (arg == "--link" && i + 1 < argc) {
      link = argv[++i];
    } else if (arg == "--rounds" && i + 1 < argc) {
      rounds = std::max(1, std::atoi(argv[++i]));
    } else if (arg == "--label" && i + 1 < argc) {
      label = argv[++i];
    } else {
      std::cerr << "peis-bench-tiny: unknown argument " << arg << "\n";
      return 2;
    }
  }
  if (link.empty() || node.empty()) {
    std::cerr
        << "usage: peis-bench-tiny roundtrip --link LINK [--rounds N] [--label T] -- NODE...\n";
    return 2;
  }
  std::random_device rd;
  const std::string ecology = "bench-tiny-" + std::to_string(getpid());
  const auto dir = "/tmp/peis-bench-tiny-" + std::to_string(getpid());
  std::string self = argv[0];
  const auto binDir = self.substr(0, self.rfind('/'));  // build/bench
  const auto build = binDir.substr(0, binDir.rfind('/'));
  unsigned mediumPort = 0;
  if (link.rfind("medium:", 0) == 0) mediumPort = static_cast<unsigned>(std::stoul(link.substr(7)));
  std::vector<std::string> env{"PEIS_LOG=quiet", "TINY_MEDIUM_SLOTS=8",
                               "TINY_MEDIUM_PORT=" + std::to_string(mediumPort)};
  if (system(("mkdir -p " + dir).c_str()) != 0) return 1;

  peis::Options options;
  options.id = 6890;
  options.name = "astrid";
  options.ecology = ecology;
  peis::Kernel astrid(options);

  host_medium sniffer{};
  bool sniffing = false;
  if (mediumPort != 0) {
    host_medium_config config{};
    config.base_port = mediumPort;
    config.slots = 8;
    sniffing = host_medium_open(&sniffer, &config) == 0;
  }
  Child nodeProcess(node, env, true);
  Child bridge({build + "/bridge/peis-tinybridge", "--link", link, "--keys",
                std::string(PEIS_SOURCE_DIR) + "/bridge/keys.yaml", "--registry",
                dir + "/keys.sqlite", "--peis-ecology", ecology},
               env);

  std::mutex mu;
  std::condition_variable changed;
  std::string lampLevel;
  astrid.subscribe(peis::Pattern("LampLevel", 7));
  astrid.onChange(peis::Pattern("LampLevel", 7), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    lampLevel = t.data;
    changed.notify_all();
  });
  auto await = [&](const std::string& value, std::chrono::milliseconds deadline) {
    std::unique_lock lock(mu);
    return changed.wait_for(lock, deadline, [&] { return lampLevel == value; });
  };
  // Warm-up: the node joined, its subscription is served, the value is back.
  bool ready = false;
  for (int attempt = 0; attempt < 60 && !ready; ++attempt) {
    astrid.set("LightValue", std::to_string(attempt % 2));
    ready = await(std::to_string(attempt % 2), 1s);
  }
  if (!ready) {
    std::cerr << "peis-bench-tiny: the lamp never answered through the bridge\n";
    return 1;
  }
  auto drainSniffer = [&](std::size_t& frames, std::size_t& bytes) {
    if (!sniffing) return;
    std::uint8_t buf[TINY_FRAME_MAX + 1];
    int n;
    while ((n = host_medium_recv(&sniffer, buf, sizeof buf)) > 0) {
      ++frames;
      bytes += static_cast<std::size_t>(n);
    }
  };
  std::size_t frames = 0, bytes = 0;
  drainSniffer(frames, bytes);
  frames = bytes = 0;
  std::vector<double> latencies;
  int lost = 0;
  const auto start = Clock::now();
  for (int i = 0; i < rounds; ++i) {
    const auto value = std::to_string(2 + i % 99);  // 2..100, never the previous one
    const auto t0 = Clock::now();
    astrid.set("LightValue", value);
    if (!await(value, 5s)) {
      ++lost;
      continue;
    }
    latencies.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    drainSniffer(frames, bytes);
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  drainSniffer(frames, bytes);
  const auto baseline = udpBaseline(std::max(rounds, 1000));
  std::printf(
      "| round trip 6890 -> bridge -> lamp -> back (%s) | p50 %s | p90 %s, p99 %s; %d rounds, "
      "%.0f /s, %d lost |\n",
      label.c_str(), us(percentile(latencies, 0.5)).c_str(), us(percentile(latencies, 0.9)).c_str(),
      us(percentile(latencies, 0.99)).c_str(), rounds,
      static_cast<double>(latencies.size()) / seconds, lost);
  if (sniffing && !latencies.empty()) {
    std::printf(
        "| frames on the air per round trip (%s) | %.2f | %.1f bytes per round trip (beacons "
        "and renewals included) |\n",
        label.c_str(), static_cast<double>(frames) / static_cast<double>(latencies.size()),
        static_cast<double>(bytes) / static_cast<double>(latencies.size()));
  }
  if (mediumPort != 0) {
    std::printf(
        "| baseline: UDP ping-pong on 127.0.0.1, 35 B (same run) | p50 %s | p90 %s, p99 %s |\n",
        us(percentile(baseline, 0.5)).c_str(), us(percentile(baseline, 0.9)).c_str(),
        us(percentile(baseline, 0.99)).c_str());
  }
  if (sniffing) host_medium_close(&sniffer);
  (void)system(("rm -rf " + dir).c_str());
  return 0;
}

int frames() {
  std::printf("| tuple data bytes | frame bytes | useful data per frame | frames per tuple |\n");
  std::printf("|---|---|---|---|\n");
  for (int data : {1, 3, 8, 16, 32, 68}) {
    tiny_tuple t{};
    tiny_key key = tiny_key1(42);
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(data), '7');
    tiny_tuple_set_key_data(&t, &key, bytes.data(), static_cast<std::uint8_t>(data));
    t.owner = t.creator = 7;
    std::uint8_t buf[TINY_FRAME_MAX];
    const auto n = tiny_encode_tuple_frame(buf, 7, 0xFFFF, 1, &t);
    std::printf("| %d | %zu | %.1f %% | 1 |\n", data, n, 100.0 * data / static_cast<double>(n));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "roundtrip") return roundtrip(argc, argv);
  if (mode == "frames") return frames();
  std::cerr << "usage: peis-bench-tiny roundtrip --link LINK [--rounds N] [--label T] -- NODE...\n"
               "       peis-bench-tiny frames\n";
  return mode == "--help" ? 0 : 2;
}
