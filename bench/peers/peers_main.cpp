// peis-bench-peers: one measurement of a peer middleware (Cyclone DDS or
// ZeroMQ) printed as one line of numbers, in the same form as
// `peis-bench-net once`, for bench/run_peer_comparison.sh. Every peer runs in
// a process of its own (this program re-run with --role).
#include <sys/prctl.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>

#include "peers.h"

namespace {

constexpr const char* kUsage =
    "Usage: peis-bench-peers once dds-rtt|zmq-rtt SIZE\n"
    "       peis-bench-peers once dds-stream|zmq-stream SIZE\n"
    "Measures Cyclone DDS or ZeroMQ over loopback between two processes and\n"
    "prints one line: for a round trip `p50 p90 p99` in microseconds (2,000\n"
    "samples, 500 at 64 KiB, after 50 warm-up rounds); for a 2 s stream\n"
    "`delivered/s delivered written lost`. bench/run_peer_comparison.sh runs it\n"
    "interleaved with peis-bench-net and tabulates medians.\n";

int once(const std::string& kind, std::size_t bytes) {
  using namespace peis::bench;
  const int count = bytes >= 65536 ? 500 : 2000;
  if (kind == "dds-rtt" || kind == "zmq-rtt") {
    const auto p = kind == "dds-rtt" ? ddsRoundTrip(bytes, count) : zmqRoundTrip(bytes, count);
    std::printf("%.2f %.2f %.2f\n", p.p50, p.p90, p.p99);
    return p.p50 > 0 ? 0 : 1;
  }
  if (kind == "dds-stream" || kind == "zmq-stream") {
    const auto r = kind == "dds-stream" ? ddsStream(bytes, 2.0) : zmqStream(bytes, 2.0);
    std::printf("%.0f %llu %llu %llu\n", r.deliveredPerSecond,
                static_cast<unsigned long long>(r.delivered),
                static_cast<unsigned long long>(r.written),
                static_cast<unsigned long long>(r.written - r.delivered));
    return r.deliveredPerSecond > 0 ? 0 : 1;
  }
  std::fprintf(stderr, "peis-bench-peers: unknown measurement '%s'\n%s", kind.c_str(), kUsage);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  if (argc == 5 && std::strcmp(argv[1], "--role") == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive the benchmark
    if (getppid() == 1) return 1;
    const std::string role = argv[2];
    const int value = std::stoi(argv[4]);
    if (role == "dds-echo") return peis::bench::ddsEchoRole(value);
    if (role == "dds-sink") return peis::bench::ddsSinkRole(value);
    if (role == "zmq-echo") return peis::bench::zmqEchoRole(value);
    if (role == "zmq-sink") return peis::bench::zmqSinkRole(value);
    return 2;
  }
  if (argc == 4 && std::strcmp(argv[1], "once") == 0) return once(argv[2], std::stoul(argv[3]));
  std::fputs(kUsage, stderr);
  return 2;
}
