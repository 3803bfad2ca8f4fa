// DirectSend: outbox entries that the thread which queued them sends itself,
// straight to their links, instead of waking the kernel thread to do it
// (docs/architecture.md, "Direct sends"). Entries are taken from the outbox
// under the kernel lock `mu`, and each link's write lock is taken then too,
// before `mu` is let go: whatever anybody sends to that link afterwards
// (flush, another direct send) queues behind these entries, so the order per
// destination holds. send() then writes them with `mu` released (a system
// call under `mu` would stall the kernel thread's receive path whenever the
// sender is preempted in it) and lets go of the links.
#pragma once

#include <boost/container/small_vector.hpp>
#include <cstdint>
#include <memory>
#include <string>

#include "net/link.h"
#include "outbox.h"

namespace peis {

class DirectSend {
 public:
  DirectSend() = default;
  DirectSend(const DirectSend&) = delete;
  DirectSend& operator=(const DirectSend&) = delete;
  ~DirectSend() { send(); }

  // Under mu: whether entries for `link` may join the batch (its write lock
  // is taken on its first admission; see Link::lockForDirect).
  bool admit(const std::shared_ptr<net::Link>& link, std::size_t mostBacklog);
  // Under mu: an entry taken from the outbox for an admitted link.
  void add(net::Link* link, Outbox::Outgoing&& entry);
  // Under mu: the envelope's source and the owner's incarnation.
  void stamp(PeisId self, std::uint64_t incarnation) {
    self_ = self;
    incarnation_ = incarnation;
  }
  bool empty() const { return links_.empty(); }
  // Without mu: sends every entry and lets go of the links.
  void send();
  // Under mu: the memory of the frames sent last on this thread, for the
  // outbox to reuse (empty when there is none).
  static std::string spareFrames();

 private:
  struct Item {
    net::Link* link;
    Outbox::Outgoing entry;
  };
  boost::container::small_vector<std::shared_ptr<net::Link>, 2> links_;
  boost::container::small_vector<Item, 2> items_;
  PeisId self_ = 0;
  std::uint64_t incarnation_ = 0;
};

}  // namespace peis
