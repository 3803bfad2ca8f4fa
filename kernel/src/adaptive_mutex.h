// AdaptiveMutex: a mutex that spins for a moment before it sleeps (glibc's
// PTHREAD_MUTEX_ADAPTIVE_NP). The kernel's lock is held for well under a
// microsecond at a time, by an application thread and the kernel thread on
// different cores; spinning then costs less than the futex sleep and wake
// (two system calls and a context switch) a plain std::mutex pays. On a
// single CPU (e.g. under `taskset -c 0`) the holder cannot run while another
// thread spins, so there it is a plain mutex.
#pragma once

#include <pthread.h>
#include <sched.h>

namespace peis {

class AdaptiveMutex {
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

  void lock() { pthread_mutex_lock(&mutex_); }
  bool try_lock() { return pthread_mutex_trylock(&mutex_) == 0; }
  void unlock() { pthread_mutex_unlock(&mutex_); }

 private:
  static int usableCpus() {
    cpu_set_t cpus;
    if (sched_getaffinity(0, sizeof cpus, &cpus) != 0) return 1;
    return CPU_COUNT(&cpus);
  }
  pthread_mutex_t mutex_;
};

}  // namespace peis
