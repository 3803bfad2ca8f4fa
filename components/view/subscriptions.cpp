// Reference-counted subscriptions with a linger (subscriptions.h).
#include "view/subscriptions.h"

namespace peis::view {

SubscriptionSet::SubscriptionSet(Subscribe subscribe, Unsubscribe unsubscribe,
                                 std::chrono::milliseconds linger)
    : subscribe_(std::move(subscribe)), unsubscribe_(std::move(unsubscribe)), linger_(linger) {}

SubscriptionSet::~SubscriptionSet() {
  for (const auto& [key, entry] : entries_) unsubscribe_(entry.handle);
}

std::string SubscriptionSet::acquire(const Pattern& pattern, Clock::time_point) {
  // Only the owner and key pattern reach the owners: the rest filters here.
  Pattern wire(pattern.keyPattern(), pattern.ownerFilter());
  const std::string key = wire.str();
  auto it = entries_.find(key);
  if (it == entries_.end()) {
    it = entries_.emplace(key, Entry{subscribe_(wire), 0, {}}).first;
  }
  ++it->second.users;
  return key;
}

void SubscriptionSet::release(const std::string& key, Clock::time_point now) {
  auto it = entries_.find(key);
  if (it == entries_.end() || it->second.users == 0) return;
  if (--it->second.users == 0) it->second.unusedSince = now;
}

void SubscriptionSet::expire(Clock::time_point now) {
  for (auto it = entries_.begin(); it != entries_.end();) {
    if (it->second.users == 0 && now - it->second.unusedSince >= linger_) {
      unsubscribe_(it->second.handle);
      it = entries_.erase(it);
    } else {
      ++it;
    }
  }
}

std::size_t SubscriptionSet::wanted(const std::string& key) const {
  auto it = entries_.find(key);
  return it == entries_.end() ? 0 : it->second.users;
}

}  // namespace peis::view
