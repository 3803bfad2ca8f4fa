// The view's interest in the ecology, reference-counted: each page's
// filter, the plotted tuple and every meta tuple of the configuration hold
// a subscription to their pattern (owner and key pattern), shared by all
// that want the same one. A pattern nobody wants any longer stays
// subscribed for a while (`linger`) before it is ended, so a page that
// flips between filters does not make the owners send their tuples again
// and again. The subscribe and unsubscribe functions are the kernel's (or a
// test's). Used on one thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include "peis/pattern.h"

namespace peis::view {

class SubscriptionSet {
 public:
  using Clock = std::chrono::steady_clock;
  using Subscribe = std::function<std::uint64_t(const Pattern&)>;
  using Unsubscribe = std::function<void(std::uint64_t handle)>;

  SubscriptionSet(Subscribe subscribe, Unsubscribe unsubscribe,
                  std::chrono::milliseconds linger = std::chrono::seconds(10));
  ~SubscriptionSet();  // ends every subscription

  // Wants `pattern` (its owner and key pattern). Returns the key to release.
  std::string acquire(const Pattern& pattern, Clock::time_point now);
  // No longer wants it; ended after `linger` unless acquired again.
  void release(const std::string& key, Clock::time_point now);
  // Ends the subscriptions that lingered long enough.
  void expire(Clock::time_point now);

  std::size_t active() const { return entries_.size(); }
  std::size_t wanted(const std::string& key) const;

 private:
  struct Entry {
    std::uint64_t handle = 0;
    std::size_t users = 0;
    Clock::time_point unusedSince{};
  };
  Subscribe subscribe_;
  Unsubscribe unsubscribe_;
  std::chrono::milliseconds linger_;
  std::map<std::string, Entry> entries_;
};

}  // namespace peis::view
