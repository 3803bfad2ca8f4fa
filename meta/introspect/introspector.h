// Introspection: keeps a LiveModel of the ecology up to date from its tuples.
// It subscribes (any owner) to what the component conventions publish —
// `kernel.all-keys`, `component.name`, `component.descriptor`, `status`,
// `cause.names`, `fact.**`, `tiny.bridge` — and to the meta-level's own
// records (`config.owned`, `config.lock`, `config.goal.**`,
// `config.configurator`); per PEIS, to every meta input `mi-*` its key list
// names and to the actuators its descriptor switches functionalities with.
// Membership (who is alive) comes from the kernel's routing table, so a PEIS
// that dies shows as gone within one liveness period, and every tuple change
// within the time its owner takes to push it. Thread-safe: callbacks run on
// the kernel thread, `snapshot()` from any thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>

#include "introspect/live_model.h"
#include "peis/kernel.h"

namespace peis::meta {

class Introspector {
 public:
  // Starts watching at once. Tool PEIS (short-lived `peis` commands) are
  // left out unless `includeTools`.
  explicit Introspector(Kernel& kernel, bool includeTools = false);
  ~Introspector();
  Introspector(const Introspector&) = delete;
  Introspector& operator=(const Introspector&) = delete;

  LiveModel snapshot() const;
  // Goes up by one with every change of the model.
  std::uint64_t version() const;
  // `fn` runs on the kernel thread after every change (keep it short: the
  // configurator only wakes its own thread). One listener; empty removes it.
  void setListener(std::function<void()> fn);
  // True when, for every alive PEIS, its key list has arrived and every key
  // of it that introspection follows has a value here.
  bool complete() const;
  // Blocks (never on the kernel thread) until the membership has not
  // changed for `quiet` and complete() holds, or `deadline` passes; returns
  // whether it settled.
  bool waitSettled(std::chrono::milliseconds deadline,
                   std::chrono::milliseconds quiet = std::chrono::milliseconds(300));

 private:
  struct State;
  std::shared_ptr<State> state_;
};

}  // namespace peis::meta
