// TimerTable: the application's timers (Kernel::after, every, cancelTimer).
// Each is a steady_timer on the kernel thread; the table, guarded by its own
// mutex, lets any thread add or cancel one. A one-shot timer leaves the table
// as it fires; a cancelled timer never runs again, even if its expiry was
// already queued. A function that throws is reported and the timer goes on.
#pragma once

#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string_view>

#include "adaptive_mutex.h"

namespace peis {

class TimerTable {
 public:
  using Handle = std::uint64_t;
  // `threw` is told (on the kernel thread) what a timer function threw.
  TimerTable(boost::asio::io_context& io, std::function<void(std::string_view)> threw);

  // A timer that fires after `delay` and then every `period` (0: once).
  Handle add(std::chrono::milliseconds delay, std::chrono::milliseconds period,
             std::function<void()> fn) EXCLUDES(mu_);
  bool cancel(Handle handle) EXCLUDES(mu_);
  // No timer runs again (the Kernel is stopping).
  void stopAll() EXCLUDES(mu_);

 private:
  struct Timer {
    std::shared_ptr<boost::asio::steady_timer> timer;
    std::function<void()> fn;
    std::chrono::milliseconds period{0};
    std::atomic<bool> active{true};
    Handle handle = 0;
  };
  void start(const std::shared_ptr<Timer>& timer, std::chrono::milliseconds delay);

  boost::asio::io_context& io_;
  std::function<void(std::string_view)> threw_;
  AdaptiveMutex mu_;
  std::map<Handle, std::shared_ptr<Timer>> timers_ GUARDED_BY(mu_);
  Handle next_ GUARDED_BY(mu_) = 1;
};

}  // namespace peis
