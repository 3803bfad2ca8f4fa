// ValueWaiter: one application thread blocked in Kernel::waitForNext until a
// tuple has a new value. The kernel hands it the stored tuple and wakes it
// with a futex: one system call each way and no lock for the woken thread
// to take again (a condition variable's waiter re-takes its mutex, which
// glibc then releases with one more futex wake). docs/architecture.md,
// "Waiting for a value".
#pragma once

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <string>

#include "peis/types.h"
#include "tuple_space.h"

namespace peis {

struct ValueWaiter {
  PeisId owner = 0;
  std::string key;
  std::uint64_t seenSeqno = 0;  // a value with another seqno is the next one
  TuplePtr value;               // written by the kernel before `ready`
  // The futex word: 0 while waiting, 1 once `value` is set (release).
  std::atomic<std::uint32_t> ready{0};

  // Sleeps until `ready` or the deadline; true when ready.
  bool waitUntil(std::chrono::steady_clock::time_point deadline) {
    while (ready.load(std::memory_order_acquire) == 0) {
      const auto left = deadline - std::chrono::steady_clock::now();
      if (left <= std::chrono::steady_clock::duration::zero()) return false;
      const auto nanos = std::chrono::duration_cast<std::chrono::nanoseconds>(left).count();
      timespec relative{static_cast<std::time_t>(nanos / 1'000'000'000),
                        static_cast<long>(nanos % 1'000'000'000)};
      // Returns at once if `ready` is no longer 0 (the wake came first);
      // EINTR and spurious returns loop.
      syscall(SYS_futex, futexWord(), FUTEX_WAIT_PRIVATE, 0u, &relative, nullptr, 0);
    }
    return true;
  }

  // Hands the waiter its value (the caller holds the kernel lock, so the
  // waiter's own check under it sees either nothing or all of it).
  void fulfil(TuplePtr tuple) {
    value = std::move(tuple);
    ready.store(1, std::memory_order_release);
  }

  // Wakes the thread if it sleeps. Called after fulfil, ideally with no lock
  // held: the woken thread may run at once (on one core, ahead of the
  // waker), and should not find the waker holding a lock it needs. The
  // caller keeps the waiter alive (a shared_ptr) until this returns.
  void wake() { syscall(SYS_futex, futexWord(), FUTEX_WAKE_PRIVATE, 1, nullptr, nullptr, 0); }

 private:
  std::uint32_t* futexWord() {
    static_assert(sizeof(ready) == sizeof(std::uint32_t) &&
                  std::atomic<std::uint32_t>::is_always_lock_free);
    return reinterpret_cast<std::uint32_t*>(&ready);
  }
};

}  // namespace peis
