// AdaptiveMutex: a mutex that spins for a moment before it sleeps (glibc's
// PTHREAD_MUTEX_ADAPTIVE_NP). The kernel's lock is held for well under a
// microsecond at a time, by an application thread and the kernel thread on
// different cores; spinning then costs less than the futex sleep and wake
// (two system calls and a context switch) a plain std::mutex pays. On a
// single CPU (e.g. under `taskset -c 0`) the holder cannot run while another
// thread spins, so there it is a plain mutex.
//
// Both it and MutexLock (its scoped holder) carry clang's thread-safety
// annotations, so members marked GUARDED_BY(mu) are checked at build time.
#pragma once

#include <pthread.h>
#include <sched.h>

#include "thread_annotations.h"

namespace peis {

class CAPABILITY("mutex") AdaptiveMutex {
 public:
  AdaptiveMutex() {
    pthread_mutexattr_t attributes;
    pthread_mutexattr_init(&attributes);
    pthread_mutexattr_settype(&attributes,
                              usableCpus() > 1 ? PTHREAD_MUTEX_ADAPTIVE_NP : PTHREAD_MUTEX_NORMAL);
    pthread_mutex_init(&mutex_, &attributes);
    pthread_mutexattr_destroy(&attributes);
  }
  ~AdaptiveMutex() { pthread_mutex_destroy(&mutex_); }
  AdaptiveMutex(const AdaptiveMutex&) = delete;
  AdaptiveMutex& operator=(const AdaptiveMutex&) = delete;

  void lock() ACQUIRE() { pthread_mutex_lock(&mutex_); }
  bool try_lock() TRY_ACQUIRE(true) { return pthread_mutex_trylock(&mutex_) == 0; }
  void unlock() RELEASE() { pthread_mutex_unlock(&mutex_); }
  // Tells the analysis that the caller holds the lock (a lambda run by a
  // function that took it: the analysis does not follow lambdas).
  void assertHeld() const ASSERT_CAPABILITY(this) {}

 private:
  static int usableCpus() {
    cpu_set_t cpus;
    if (sched_getaffinity(0, sizeof cpus, &cpus) != 0) return 1;
    return CPU_COUNT(&cpus);
  }
  pthread_mutex_t mutex_;
};

// Holds an AdaptiveMutex for its scope (std::unique_lock's role, annotated).
// It is BasicLockable, so a std::condition_variable_any can wait on it.
class SCOPED_CAPABILITY MutexLock {
 public:
  explicit MutexLock(AdaptiveMutex& mutex) ACQUIRE(mutex) : mutex_(mutex) { mutex_.lock(); }
  ~MutexLock() RELEASE() {
    if (held_) mutex_.unlock();
  }
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  // For condition_variable_any::wait (which unlocks and locks again) and
  // for callers that release early.
  void lock() ACQUIRE() {
    mutex_.lock();
    held_ = true;
  }
  void unlock() RELEASE() {
    held_ = false;
    mutex_.unlock();
  }

 private:
  AdaptiveMutex& mutex_;
  bool held_ = true;
};

}  // namespace peis
