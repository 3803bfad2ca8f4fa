// peis-bench-local: what one PEIS costs on its own (no network): tuple space
// writes and reads, and the latency from a set() on an application thread to
// the callback on the kernel thread. Prints Markdown table rows.
#include <peis/peis.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

#include "tuple_space.h"

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

std::string sizeName(std::size_t bytes) {
  return bytes >= 1024 ? std::to_string(bytes / 1024) + " KiB" : std::to_string(bytes) + " B";
}

void benchSpaceWrites(std::size_t bytes) {
  peis::TupleSpace space(1, peis::systemNow);
  const std::string data(bytes, 'x');
  const int count = bytes >= 65536 ? 20000 : 500000;
  const auto start = Clock::now();
  for (int i = 0; i < count; ++i) space.set("bench.value", data);
  const double s = seconds(Clock::now() - start);
  std::printf("| TupleSpace::set, one key | %s | %.0f /s | %.1f MB/s |\n", sizeName(bytes).c_str(),
              count / s, count * static_cast<double>(bytes) / s / 1e6);
}

void benchKernelGets() {
  peis::Options options;
  options.id = 1;
  peis::Kernel kernel(options);
  kernel.set("bench.value", std::string(16, 'x'));
  const int count = 1000000;
  std::size_t total = 0;
  const auto start = Clock::now();
  for (int i = 0; i < count; ++i) total += kernel.get("bench.value")->data.size();
  const double s = seconds(Clock::now() - start);
  std::printf("| Kernel::get (local read) | 16 B | %.0f /s | checksum %zu |\n", count / s, total);
}

void benchCallbackLatency(std::size_t bytes) {
  peis::Options options;
  options.id = 1;
  peis::Kernel kernel(options);
  std::mutex mu;
  std::condition_variable cv;
  std::uint64_t seen = 0;
  kernel.onChange(peis::Pattern("bench.value", 1), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    seen = t.seqno;
    cv.notify_one();
  });
  const std::string data(bytes, 'x');
  std::vector<double> micros;
  const int count = 20000;
  for (int i = 0; i < count; ++i) {
    const auto start = Clock::now();
    const auto seqno = kernel.set("bench.value", data).seqno;
    std::unique_lock lock(mu);
    cv.wait(lock, [&] { return seen >= seqno; });
    micros.push_back(seconds(Clock::now() - start) * 1e6);
  }
  std::sort(micros.begin(), micros.end());
  auto pct = [&](double p) { return micros[static_cast<std::size_t>(p * (micros.size() - 1))]; };
  std::printf(
      "| set -> callback on kernel thread | %s | p50 %.1f us | p90 %.1f us, p99 %.1f us |\n",
      sizeName(bytes).c_str(), pct(0.5), pct(0.9), pct(0.99));
}

long rssKib() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

void benchIdleRss() {
  const long before = rssKib();
  peis::Options options;
  options.id = 1;
  peis::Kernel kernel(options);
  std::printf("| idle Kernel, resident memory added | - | %ld KiB | process total %ld KiB |\n",
              rssKib() - before, rssKib());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && (std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0)) {
    std::printf("Usage: peis-bench-local\nPrints Markdown rows: local tuple-space costs.\n");
    return 0;
  }
  std::printf("| what | size | rate / p50 | detail |\n|---|---|---|---|\n");
  benchIdleRss();
  for (std::size_t bytes : {16u, 1024u, 65536u}) benchSpaceWrites(bytes);
  benchKernelGets();
  for (std::size_t bytes : {16u, 1024u, 65536u}) benchCallbackLatency(bytes);
  return 0;
}
