// The executing side of the ExecGoal protocol on a Kernel, shared by every
// component that takes actions (navigation, talk output, vacuum cleaner):
// a write gate refuses remote ExecGoal writes that are not a well-formed
// action the component supports (the writer's set fails with `Refused` and
// the reason), accepted goals reach `onGoal` with their seqno as goal id on
// the kernel thread, and `publish` writes ExecStatus. A malformed local
// write (e.g. --peis-set-tuple) cannot be refused; it is reported
// `failed <id> Malformed malformed goal '…': <why>`.
#pragma once

#include <peis/kernel.h>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "execution/exec_protocol.h"

namespace peis::exec {

class ExecServer {
 public:
  // Checks a well-formed action: nothing if the component takes it, else why not.
  using Check = std::function<std::optional<std::string>(const Action&)>;
  using OnGoal = std::function<void(const Action&, std::uint64_t goalId)>;

  // Installs the write gate and the callback. The kernel's write gate is the
  // server's (one per Kernel); `otherGate` is asked about other keys.
  ExecServer(Kernel& kernel, Check check, OnGoal onGoal, WriteGate otherGate = {});
  ~ExecServer();
  ExecServer(const ExecServer&) = delete;
  ExecServer& operator=(const ExecServer&) = delete;

  void publish(const ExecStatus& status);
  std::uint64_t refused() const { return refused_; }

 private:
  Kernel& kernel_;
  Check check_;
  OnGoal onGoal_;
  CallbackHandle callback_ = 0;
  std::uint64_t refused_ = 0;
};

// Seconds since the epoch of a tuple's ts_user (sensor time), or nothing when unset.
std::optional<double> sensorSeconds(const Tuple& tuple);
// "1.5 2 -0.3" -> {1.5, 2, -0.3}; nothing if a field is not a finite number.
std::optional<std::vector<double>> parseNumbers(std::string_view text);

// Calls `then(id)` on the kernel thread once a PEIS named `name` (or with
// that id) is known, retrying every 100 ms.
void whenPeerKnown(Kernel& kernel, const std::string& name, std::function<void(PeisId)> then);
// The same with a deadline: `then(id)` once known, or `then(nothing)` after
// `timeout` (a PEIS that has not joined the ecology yet gets that long).
void resolvePeer(Kernel& kernel, const std::string& name, std::chrono::milliseconds timeout,
                 std::function<void(std::optional<PeisId>)> then);

}  // namespace peis::exec
