// QuietTrim: hands freed heap memory back to the system once the ecology has
// been quiet for a while. A join of many PEIS allocates and frees a lot on
// the kernel thread (full route adverts, link buffers); glibc keeps the
// freed pages of its arena resident (it trims only the top of a heap), so
// a PEIS would keep the memory of its join for good. It trims only while
// little data moves too: a trim in the middle of a stream gives back pages
// the stream's buffers then fault in again, a stall of the kernel thread.
// Kernel thread only (docs/architecture.md, "Memory after a join").
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdint>
#include <functional>

namespace peis {

class QuietTrim {
 public:
  static constexpr std::chrono::seconds kQuietFor{2};

  // More frames than this in a quiet period: data is moving, wait.
  static constexpr std::uint64_t kBusyFrames = 1000;

  // `frames`: a count of the frames sent and received so far.
  QuietTrim(boost::asio::io_context& io, std::function<std::uint64_t()> frames,
            std::chrono::steady_clock::duration quietFor = kQuietFor)
      : timer_(io), frames_(std::move(frames)), quietFor_(quietFor) {}

  // Something that allocates much changed (the topology): trim once the
  // quiet period (kQuietFor) has passed since the last such change.
  void noteChange();
  void stop() { timer_.cancel(); }
  // How many times memory was handed back (for tests and benchmarks).
  int trims() const { return trims_; }

 private:
  void arm(std::chrono::steady_clock::time_point at);

  boost::asio::steady_timer timer_;
  const std::function<std::uint64_t()> frames_;
  const std::chrono::steady_clock::duration quietFor_;
  std::uint64_t framesAtArm_ = 0;
  std::chrono::steady_clock::time_point changedAt_{};
  bool armed_ = false;
  int trims_ = 0;
};

}  // namespace peis
