// Watching one tuple of another PEIS so that its current value is an event
// too: callbacks, then the subscription, then the value the local cache
// already holds. The kernel hands a callback only *changes* (a tuple whose
// seqno is newer than the cached one): when another subscription — the
// runner's `**` of the same owner, for the trace — brought the value before
// this tuple's callbacks existed, the fresh subscription brings the same
// seqno again, which is no change, and a one-shot value (the plant's
// TiltValue, the blind's BlindPosition, the parcel's Weight, the world's
// place.bed) was never seen. That was the runner's flaky "the blind
// closes" and "the parcel weighs" under load. Each value is handed on once
// (by seqno), whichever way it came first.
#pragma once

#include <peis/kernel.h>

#include <functional>
#include <memory>
#include <mutex>

namespace peis::scenario {

class TupleWatch {
 public:
  // `onValue` gets the tuple, or nullptr when it was deleted; on the kernel
  // thread, or on the caller's thread for the cached value.
  using Callback = std::function<void(const Tuple*)>;
  TupleWatch(Kernel& kernel, PeisId owner, std::string key, Callback onValue);
  TupleWatch(const TupleWatch&) = delete;
  TupleWatch& operator=(const TupleWatch&) = delete;

 private:
  struct Shared {
    std::mutex mu;
    std::uint64_t lastSeqno = 0;
    Callback onValue;
    void hand(const Tuple* t);
  };
  std::shared_ptr<Shared> shared_;
};

}  // namespace peis::scenario
