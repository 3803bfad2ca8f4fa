// The launcher's state machine with a hand-moved clock: start and stop,
// SIGTERM then SIGKILL after the grace, crashes restarted with doubling
// back-off until max-restarts, then failed; a long run ends a row of
// restarts; a program that cannot start fails at once.
#include "launcher/supervisor.h"

#include <catch2/catch.hpp>
#include <csignal>

using peis::launcher::Actions;
using peis::launcher::Phase;
using peis::launcher::RestartPolicy;
using peis::launcher::RestartRules;
using peis::launcher::Supervisor;
using peis::launcher::TimePoint;
using namespace std::chrono_literals;

namespace {

RestartRules rules() {
  RestartRules r;
  r.maxRestarts = 3;
  r.backoff = 100ms;
  r.maxBackoff = 300ms;
  r.resetAfter = 10s;
  r.stopGrace = 2s;
  return r;
}

const Actions kStart = peis::launcher::startProcess();
const Actions kNothing{};
const Actions kTerm = peis::launcher::sendSignal(SIGTERM);
const Actions kKill = peis::launcher::sendSignal(SIGKILL);

}  // namespace

TEST_CASE("supervisor: on starts, off stops with SIGTERM, the exit ends it", "[unit]") {
  Supervisor s(rules());
  TimePoint t{};
  CHECK(s.published().currState == "off");
  CHECK(s.request("on", t) == kStart);
  CHECK(s.published().currState == "starting");
  CHECK(s.published().status == "busy");
  CHECK(s.started(4242, t) == kNothing);
  CHECK(s.published().currState == "on");
  CHECK(s.published().status == "ok");
  CHECK(s.published().pid == 4242);
  CHECK(s.request("on", t) == kNothing);  // already on
  CHECK(s.request("off", t + 1s) == kTerm);
  CHECK(s.published().currState == "stopping");
  CHECK(s.deadline() == t + 1s + 2s);
  CHECK(s.exited(-SIGTERM, t + 1500ms) == kNothing);
  CHECK(s.published().currState == "off");
  CHECK(s.published().status == "ok");
  CHECK_FALSE(s.published().pid);
  CHECK(s.published().exitCode == -SIGTERM);
  CHECK_FALSE(s.deadline());
  CHECK_FALSE(s.processAlive());
}

TEST_CASE("supervisor: a program that ignores SIGTERM gets SIGKILL after the grace", "[unit]") {
  Supervisor s(rules());
  TimePoint t{};
  s.request("on", t);
  s.started(7, t);
  CHECK(s.request("off", t) == kTerm);
  CHECK(s.timerFired(t + 1999ms) == kNothing);  // early: not yet
  CHECK(s.timerFired(t + 2s) == kKill);
  CHECK(s.published().currState == "stopping");
  CHECK(s.exited(-SIGKILL, t + 2100ms) == kNothing);
  CHECK(s.published().currState == "off");
  CHECK(s.published().exitCode == -SIGKILL);
}

TEST_CASE("supervisor: crashes restart with doubling back-off, then failed", "[unit]") {
  Supervisor s(rules());
  TimePoint t{};
  s.request("on", t);
  s.started(1, t);
  // Each run dies at once; back-offs 100, 200, 300 (the cap) ms.
  const std::chrono::milliseconds waits[] = {100ms, 200ms, 300ms};
  for (int i = 0; i < 3; ++i) {
    CHECK(s.exited(3, t) == kNothing);
    CHECK(s.published().currState == "restarting");
    CHECK(s.published().restarts == i + 1);
    CHECK(s.published().exitCode == 3);
    REQUIRE(s.deadline());
    CHECK(*s.deadline() - t == waits[i]);
    t = *s.deadline();
    CHECK(s.timerFired(t) == kStart);
    CHECK(s.started(10 + i, t) == kNothing);
  }
  CHECK(s.exited(3, t) == kNothing);
  CHECK(s.published().currState == "failed");
  CHECK(s.published().status ==
        "error: exited with status 3, 3 restarts in a row (max-restarts 3)");
  CHECK_FALSE(s.deadline());
  // A new request starts it again with a fresh count.
  CHECK(s.request("on", t) == kStart);
  CHECK(s.published().restarts == 0);
}

TEST_CASE("supervisor: a run longer than reset-after ends the row of restarts", "[unit]") {
  Supervisor s(rules());
  TimePoint t{};
  s.request("on", t);
  s.started(1, t);
  s.exited(1, t);
  t = *s.deadline();
  s.timerFired(t);
  s.started(2, t);
  s.exited(1, t + 1s);  // short run: the row goes on
  CHECK(s.published().restarts == 2);
  t = *s.deadline();
  s.timerFired(t);
  s.started(3, t);
  s.exited(-SIGSEGV, t + 11s);  // a long run, then a crash: restart number 1 again
  CHECK(s.published().restarts == 1);
  CHECK(s.published().exitCode == -SIGSEGV);
}

TEST_CASE("supervisor: restart policies", "[unit]") {
  auto r = rules();
  SECTION("on-failure: a clean exit is off, with reqState still on") {
    Supervisor s(r);
    s.request("on", {});
    s.started(1, {});
    CHECK(s.exited(0, {}) == kNothing);
    CHECK(s.published().currState == "off");
    CHECK(s.published().status == "ok");
  }
  SECTION("never: a crash is off, its status says how it ended") {
    r.policy = RestartPolicy::Never;
    Supervisor s(r);
    s.request("on", {});
    s.started(1, {});
    s.exited(-SIGKILL, {});
    CHECK(s.published().currState == "off");
    CHECK(s.published().status == "error: killed by signal 9 (KILL)");
  }
  SECTION("always: a clean exit is restarted too") {
    r.policy = RestartPolicy::Always;
    Supervisor s(r);
    s.request("on", {});
    s.started(1, {});
    s.exited(0, {});
    CHECK(s.published().currState == "restarting");
  }
}

TEST_CASE("supervisor: a program that cannot start fails at once", "[unit]") {
  Supervisor s(rules());
  s.request("on", {});
  CHECK(s.startFailed("executable 'nope' not found (c.yaml:2)", {}) == kNothing);
  CHECK(s.published().currState == "failed");
  CHECK(s.published().status == "error: executable 'nope' not found (c.yaml:2)");
  CHECK_FALSE(s.deadline());
  CHECK(s.request("off", {}) == kNothing);
  CHECK(s.published().currState == "off");
  CHECK(s.published().status == "ok");
}

TEST_CASE("supervisor: requests while starting, stopping or waiting to restart", "[unit]") {
  TimePoint t{};
  SECTION("off while starting: stopped as soon as it runs") {
    Supervisor s(rules());
    s.request("on", t);
    CHECK(s.request("off", t) == kNothing);
    CHECK(s.started(5, t) == kTerm);
    CHECK(s.published().currState == "stopping");
  }
  SECTION("on while stopping: started again once it ended") {
    Supervisor s(rules());
    s.request("on", t);
    s.started(5, t);
    s.request("off", t);
    CHECK(s.request("on", t) == kNothing);
    CHECK(s.exited(-SIGTERM, t) == kStart);
    CHECK(s.published().currState == "starting");
  }
  SECTION("off while waiting to restart: off at once") {
    Supervisor s(rules());
    s.request("on", t);
    s.started(5, t);
    s.exited(2, t);
    CHECK(s.request("off", t) == kNothing);
    CHECK(s.published().currState == "off");
    CHECK_FALSE(s.deadline());
  }
  SECTION("a bad request is an error in status and changes nothing") {
    Supervisor s(rules());
    CHECK(s.request("maybe", t) == kNothing);
    CHECK(s.published().currState == "off");
    CHECK(s.published().status == "error: reqState must be on or off, not 'maybe'");
  }
}

TEST_CASE("exits are described for people", "[unit]") {
  CHECK(peis::launcher::describeExit(0) == "exited with status 0");
  CHECK(peis::launcher::describeExit(-SIGTERM) == "killed by signal 15 (TERM)");
}
