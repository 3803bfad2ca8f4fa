// The life of one launched component (see supervisor.h).
#include "launcher/supervisor.h"

#include <string.h>

#include <csignal>

#include "peis/conventions.h"

namespace peis::launcher {

const char* currState(Phase phase) {
  switch (phase) {
    // The constants are string literals: data() is terminated.
    case Phase::Off:
      return conventions::kLaunchOff.data();
    case Phase::Starting:
      return conventions::kLaunchStarting.data();
    case Phase::On:
      return conventions::kLaunchOn.data();
    case Phase::Stopping:
    case Phase::Killing:
      return conventions::kLaunchStopping.data();
    case Phase::Restarting:
      return conventions::kLaunchRestarting.data();
    case Phase::Failed:
      return conventions::kLaunchFailed.data();
  }
  return "?";
}

std::string describeExit(int code) {
  if (code >= 0) return "exited with status " + std::to_string(code);
  const char* name = sigabbrev_np(-code);
  return "killed by signal " + std::to_string(-code) + (name ? std::string(" (") + name + ")" : "");
}

std::chrono::milliseconds Supervisor::backoffBefore(int n) const {
  auto wait = rules_.backoff;
  for (int i = 1; i < n && wait < rules_.maxBackoff; ++i) wait *= 2;
  return std::min(wait, rules_.maxBackoff);
}

void Supervisor::enter(Phase phase, std::string status) {
  phase_ = phase;
  published_.currState = currState(phase);
  if (status.empty()) {
    const bool settled = phase == Phase::On || phase == Phase::Off;
    status = settled ? "ok" : "busy";
  }
  published_.status = std::move(status);
  if (phase != Phase::On && phase != Phase::Stopping && phase != Phase::Killing)
    published_.pid.reset();
}

Actions Supervisor::startNow(TimePoint now) {
  deadline_.reset();
  startedAt_ = now;
  enter(Phase::Starting);
  return startProcess();
}

Actions Supervisor::request(std::string_view wanted, TimePoint now) {
  if (wanted != "on" && wanted != "off") {
    published_.status = "error: reqState must be on or off, not '" + std::string(wanted) + "'";
    return {};
  }
  wantOn_ = wanted == "on";
  switch (phase_) {
    case Phase::Off:
    case Phase::Failed:
      published_.restarts = 0;
      if (wantOn_) return startNow(now);
      enter(Phase::Off);
      return {};
    case Phase::Restarting:
      if (wantOn_) return {};
      deadline_.reset();
      published_.restarts = 0;
      enter(Phase::Off);
      return {};
    case Phase::On:
      if (wantOn_) {
        published_.status = "ok";  // clears an earlier bad request
        return {};
      }
      deadline_ = now + rules_.stopGrace;
      enter(Phase::Stopping);
      return sendSignal(SIGTERM);
    case Phase::Starting:  // started() stops it if off is still wanted then
    case Phase::Stopping:  // exited() starts it again if on is wanted then
    case Phase::Killing:
      if (phase_ != Phase::Starting) published_.status = "busy";
      return {};
  }
  return {};
}

Actions Supervisor::started(int pid, TimePoint now) {
  if (phase_ != Phase::Starting) return {};
  published_.pid = pid;
  if (!wantOn_) {
    deadline_ = now + rules_.stopGrace;
    enter(Phase::Stopping);
    return sendSignal(SIGTERM);
  }
  enter(Phase::On);
  return {};
}

Actions Supervisor::startFailed(const std::string& why, TimePoint) {
  if (phase_ != Phase::Starting) return {};
  // A program that cannot be run will not run on a retry either.
  enter(Phase::Failed, "error: " + why);
  return {};
}

Actions Supervisor::exited(int code, TimePoint now) {
  published_.exitCode = code;
  const Phase was = phase_;
  deadline_.reset();
  if (was == Phase::Stopping || was == Phase::Killing || !wantOn_) {
    if (wantOn_) return startNow(now);
    enter(Phase::Off);
    return {};
  }
  if (was != Phase::On) return {};
  const bool failure = code != 0;
  const bool restart = rules_.policy == RestartPolicy::Always ||
                       (rules_.policy == RestartPolicy::OnFailure && failure);
  if (!restart) {
    enter(Phase::Off, failure ? "error: " + describeExit(code) : "ok");
    return {};
  }
  if (now - startedAt_ >= rules_.resetAfter) published_.restarts = 0;
  if (published_.restarts >= rules_.maxRestarts) {
    enter(Phase::Failed,
          "error: " + describeExit(code) + ", " + std::to_string(published_.restarts) +
              " restarts in a row (max-restarts " + std::to_string(rules_.maxRestarts) + ")");
    return {};
  }
  ++published_.restarts;
  deadline_ = now + backoffBefore(published_.restarts);
  enter(Phase::Restarting);
  return {};
}

Actions Supervisor::timerFired(TimePoint now) {
  if (!deadline_ || now < *deadline_) return {};
  deadline_.reset();
  if (phase_ == Phase::Restarting) return startNow(now);
  if (phase_ == Phase::Stopping) {
    enter(Phase::Killing);
    return sendSignal(SIGKILL);
  }
  return {};
}

}  // namespace peis::launcher
