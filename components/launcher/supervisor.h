// Supervisor: the life of one launched component as a pure state machine.
// It is told what was asked (reqState), what happened to the process
// (started, could not start, exited) and when its one timer fired, and
// answers what to do (start a process, send a signal) and when it next wants
// the timer. No processes, no clock, no tuples: the launcher's shell does
// those, and tests drive it with a hand-moved clock.
//
//   off ──on──▶ starting ──started──▶ on ──exit (crash)──▶ restarting ──timer──▶ starting
//                  │                   │                      (back-off doubles; more than
//             cannot start          off: SIGTERM               max-restarts in a row: failed)
//                  ▼                   ▼
//               failed             stopping ──grace──▶ SIGKILL ──exit──▶ off
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <string_view>

#include "launcher/component_file.h"

namespace peis::launcher {

using TimePoint = std::chrono::steady_clock::time_point;

enum class Phase { Off, Starting, On, Stopping, Killing, Restarting, Failed };

// The value of components.<name>.currState for a phase.
const char* currState(Phase phase);

// What the shell must do after a step.
struct Actions {
  bool start = false;         // start a new process
  std::optional<int> signal;  // send this signal to the running process
  bool operator==(const Actions&) const = default;
};

inline Actions startProcess() {
  Actions a;
  a.start = true;
  return a;
}
inline Actions sendSignal(int signal) {
  Actions a;
  a.signal = signal;
  return a;
}

// What the launcher publishes about the component.
struct Published {
  std::string currState = "off";
  std::string status = "ok";  // ok, busy or "error: ..."
  std::optional<int> pid;
  std::optional<int> exitCode;  // the last run's: >= 0 exit status, -N killed by signal N
  int restarts = 0;             // restarts in the current row
  bool operator==(const Published&) const = default;
};

// "exited with status 3", "killed by signal 9 (KILL)".
std::string describeExit(int code);

class Supervisor {
 public:
  explicit Supervisor(RestartRules rules) : rules_(rules) {}

  // A write of reqState: "on" or "off" (anything else is an error in status).
  Actions request(std::string_view wanted, TimePoint now);
  // The process of the last `start` is running with this pid.
  Actions started(int pid, TimePoint now);
  // The last `start` could not run the program.
  Actions startFailed(const std::string& why, TimePoint now);
  // The process ended: exit status >= 0, or -N for signal N.
  Actions exited(int code, TimePoint now);
  // The timer fired (the shell may call it late or spuriously; it checks).
  Actions timerFired(TimePoint now);

  // When the shell should call timerFired next, if at all.
  std::optional<TimePoint> deadline() const { return deadline_; }
  Phase phase() const { return phase_; }
  const Published& published() const { return published_; }
  // True while a process of this component may be alive.
  bool processAlive() const {
    return phase_ == Phase::On || phase_ == Phase::Stopping || phase_ == Phase::Killing ||
           phase_ == Phase::Starting;
  }
  // The back-off before restart number `n` (1, 2, ...).
  std::chrono::milliseconds backoffBefore(int n) const;

 private:
  Actions startNow(TimePoint now);
  void enter(Phase phase, std::string status = {});

  RestartRules rules_;
  Phase phase_ = Phase::Off;
  bool wantOn_ = false;
  TimePoint startedAt_{};
  std::optional<TimePoint> deadline_;
  Published published_;
};

}  // namespace peis::launcher
