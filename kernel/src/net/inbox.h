// Inbox: the routed messages for this PEIS decoded from one read, handed to
// the kernel together. Its messages outlive a hand-over: the next read
// decodes into them again, so a stream's frames construct and destroy no
// message, and a tuple's key, mimetype and data keep their memory from one
// update to the next (docs/architecture.md, "Memory of a stream").
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "net/wire.h"

namespace peis::net {

class Inbox {
 public:
  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }
  // The next message, as the last one decoded into its place left it.
  wire::RoutedMessage& emplace_back() {
    if (size_ == kept_.size()) kept_.emplace_back();
    return kept_[size_++];
  }
  void push_back(wire::RoutedMessage&& message) { emplace_back() = std::move(message); }
  wire::RoutedMessage& back() { return kept_[size_ - 1]; }
  // Gives the last message back (kept for the next one).
  void pop_back() { --size_; }
  std::span<wire::RoutedMessage> messages() { return {kept_.data(), size_}; }
  // Empties it once its messages were handled. What a message holds beyond
  // a small tuple update (a big value, another kind of message) is let go,
  // and at most kMaxKept messages are kept.
  void clear() {
    for (std::size_t i = 0; i < size_; ++i) {
      auto& body = kept_[i].body;
      auto* update = std::get_if<wire::TupleUpdate>(&body);
      if (!update) {
        body.emplace<wire::TupleUpdate>();
      } else if (update->tuple.data.capacity() > kMaxKeptDataBytes) {
        update->tuple.data = std::string();
      }
    }
    size_ = 0;
    if (kept_.size() > kMaxKept) kept_.resize(kMaxKept);
  }
  void swap(Inbox& other) noexcept {
    kept_.swap(other.kept_);
    std::swap(size_, other.size_);
  }
  std::size_t capacity() const { return kept_.size(); }

  static constexpr std::size_t kMaxKept = 1024;
  static constexpr std::size_t kMaxKeptDataBytes = 256;

 private:
  std::vector<wire::RoutedMessage> kept_;  // the first size_ are this read's
  std::size_t size_ = 0;
};

}  // namespace peis::net
