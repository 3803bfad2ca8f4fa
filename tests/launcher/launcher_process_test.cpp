// peis-init as a separate process in an ecology of its own, driven through
// its tuples by an in-process PEIS the way the configurator drives it: a
// PEIS component started and stopped by remote writes of reqState; a
// missing executable; a program that exits at once in a loop (back-off,
// then failed); one that ignores SIGTERM (SIGKILL after the grace); broken
// and unknown component files; the launcher stopping, or being killed,
// takes its components along and nothing else.
#include <signal.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "support/integration.h"
#include "support/temp_dir.h"

using namespace peis::test;
using namespace std::chrono_literals;

namespace {

// True once `pid` has ended (gone, or a zombie nobody reaped yet).
bool processGone(pid_t pid) {
  if (::kill(pid, 0) != 0) return true;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  std::getline(stat, text);
  const auto close = text.rfind(')');
  return close == std::string::npos || (close + 2 < text.size() && text[close + 2] == 'Z');
}

// One peis-init process with the component files of a folder, and an
// observer PEIS subscribed to its tuples.
struct LauncherFixture {
  std::string ecology;
  TempDir dir{"launcher"};
  std::unique_ptr<Process> launcher;
  std::unique_ptr<peis::Kernel> observer;
  peis::PeisId id = 0;
  Recorder states;  // every "<name> <currState>" the observer saw, in order

  explicit LauncherFixture(const std::string& tag) : ecology(uniqueEcology(tag)) {}

  void file(const std::string& name, const std::string& yaml) { dir.write(name + ".yaml", yaml); }

  void start(std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{PEIS_INIT_PATH, dir.path.string(), "--peis-ecology", ecology};
    argv.insert(argv.end(), extra.begin(), extra.end());
    launcher = std::make_unique<Process>(argv, Process::Environment{{"PEIS_LOG", "info"}});
    observer = std::make_unique<peis::Kernel>(kernelOptions(ecology, "observer"));
    const auto found = observer->waitForPeer("launcher", kDeadline);
    INFO(launcher->describe());
    REQUIRE(found);
    id = *found;
    observer->onChange(peis::Pattern("components.*.currState", id), [this](const peis::Tuple& t) {
      const auto name = t.key.substr(11, t.key.size() - 11 - 10);
      states.add(name + " " + t.data);
    });
    observer->subscribe(peis::Pattern("components.**", id));
    observer->subscribe(peis::Pattern("launcher.*", id));
    observer->subscribe(peis::Pattern("status", id));
  }

  std::string value(const std::string& component, const std::string& field) const {
    return valueOf(*observer, id, "components." + component + "." + field);
  }
  // True when the last currState the observer's callback saw for
  // `component` is `state`. The launcher writes currState last, so its
  // other tuples (status, pid, exitCode, restarts) are in the cache by then.
  bool reached(const std::string& component, const std::string& state) const {
    const auto seen = states.entries();
    for (auto it = seen.rbegin(); it != seen.rend(); ++it) {
      if (it->rfind(component + " ", 0) == 0) return *it == component + " " + state;
    }
    return false;
  }
  // A remote write of reqState, as the configurator makes it.
  void request(const std::string& component, const std::string& state) {
    observer->set(id, "components." + component + ".reqState", state);
  }
  std::string report() const {
    return launcher->describe() + "\n--- states seen ---\n" + states.text();
  }
};

}  // namespace

TEST_CASE("peis-init starts and stops a PEIS component when its reqState is written",
          "[integration]") {
  LauncherFixture f("init-start-stop");
  const std::string peisName = "worker-" + std::to_string(randomId());
  f.file("worker", "name: worker\nexecutable: " + std::string(PEIS_CLI_PATH) +
                       "\narguments: [node]\npeis: {name: " + peisName +
                       "}\nenvironment: {PEIS_LOG: info}\nstop-grace: 10\n");
  f.start();
  StateReport report([&] { return f.report(); });
  REQUIRE_WAIT([&] { return f.reached("worker", "off"); }, kDeadline);
  CHECK(f.value("worker", "peisName") == peisName);
  REQUIRE_WAIT([&] { return valueOf(*f.observer, f.id, "launcher.components") == "worker"; },
               kDeadline);
  REQUIRE_WAIT([&] { return valueOf(*f.observer, f.id, "status") == "running"; }, kDeadline);

  f.request("worker", "on");
  REQUIRE_WAIT([&] { return f.reached("worker", "on"); }, kDeadline);
  const pid_t pid = std::stoi(f.value("worker", "pid"));
  CHECK(f.value("worker", "status") == "ok");
  // The component joined the launcher's ecology under the name its file gives.
  const auto worker = f.observer->waitForPeer(peisName, kDeadline);
  REQUIRE(worker);
  REQUIRE_WAIT(
      [&] { return f.value("worker", "stderr").find("peis node: PEIS") != std::string::npos; },
      kDeadline);

  f.request("worker", "off");
  REQUIRE_WAIT([&] { return f.reached("worker", "off"); }, kDeadline);
  CHECK(f.value("worker", "exitCode") == "0");  // peis node ends cleanly on SIGTERM
  CHECK(f.value("worker", "pid").empty());
  CHECK(processGone(pid));
  REQUIRE_WAIT([&] { return !hasPeer(*f.observer, *worker); }, kDeadline);
  CHECK(f.states.text() == "worker off\nworker starting\nworker on\nworker stopping\nworker off\n");

  // A bad request is refused in status; the component stays as it is.
  f.request("worker", "maybe");
  REQUIRE_WAIT([&] {
    return f.value("worker", "status") == "error: reqState must be on or off, not 'maybe'";
  });
  CHECK(f.value("worker", "currState") == "off");
}

TEST_CASE("peis-init: a missing executable fails that component only", "[fault]") {
  LauncherFixture f("init-missing");
  f.file("ghost", "name: ghost\nexecutable: ./no-such-program\nstart: on\n");
  f.file(
      "sleeper",
      "name: sleeper\nexecutable: sh\narguments: [-c, 'echo hello; exec sleep 600']\nstart: on\n");
  f.start();
  StateReport report([&] { return f.report(); });
  REQUIRE_WAIT([&] { return f.reached("ghost", "failed"); }, kDeadline);
  CHECK(f.value("ghost", "status") == "error: executable '" + f.dir.file("no-such-program") +
                                          "' not found (" + f.dir.file("ghost.yaml") + ":2)");
  REQUIRE_WAIT([&] { return f.reached("sleeper", "on"); }, kDeadline);
  REQUIRE_WAIT([&] { return f.value("sleeper", "stdout") == "hello"; }, kDeadline);
  CHECK(f.launcher->running());
}

TEST_CASE("peis-init: a program that exits at once is restarted with back-off, then failed",
          "[fault]") {
  LauncherFixture f("init-crashloop");
  f.file("crasher",
         "name: crasher\nexecutable: sh\narguments: [-c, 'echo dying >&2; exit 3']\n"
         "restart: {backoff: 0.05, max-backoff: 0.2, max-restarts: 3}\n");
  f.start();
  StateReport report([&] { return f.report(); });
  // Started only once the observer's subscription is seen to work: with
  // `start: on` the first runs may be over before the observer links, and
  // a subscription brings the current state, not the states before it.
  REQUIRE_WAIT([&] { return f.reached("crasher", "off"); }, kDeadline);
  f.request("crasher", "on");
  REQUIRE_WAIT([&] { return f.reached("crasher", "failed"); }, kDeadline);
  CHECK(f.value("crasher", "status") ==
        "error: exited with status 3, 3 restarts in a row (max-restarts 3)");
  CHECK(f.value("crasher", "restarts") == "3");
  CHECK(f.value("crasher", "exitCode") == "3");
  CHECK(f.value("crasher", "stderr").find("dying") != std::string::npos);
  // Four runs: the first and three restarts, each after a back-off.
  const auto seen = f.states.entries();
  CHECK(std::count(seen.begin(), seen.end(), "crasher restarting") == 3);
  CHECK(seen.back() == "crasher failed");
  // It stays failed: no more runs.
  CHECK(f.value("crasher", "pid").empty());
}

TEST_CASE("peis-init: a program that ignores SIGTERM is killed after the grace", "[fault]") {
  LauncherFixture f("init-stubborn");
  f.file("stubborn",
         "name: stubborn\nexecutable: sh\narguments: [-c, 'trap \"\" TERM; echo ready; "
         "while :; do sleep 0.1; done']\nstart: on\nstop-grace: 0.5\n");
  f.start();
  StateReport report([&] { return f.report(); });
  REQUIRE_WAIT([&] { return f.value("stubborn", "stdout") == "ready"; }, kDeadline);
  REQUIRE(f.value("stubborn", "currState") == "on");
  const pid_t pid = std::stoi(f.value("stubborn", "pid"));
  f.request("stubborn", "off");
  REQUIRE_WAIT([&] { return f.reached("stubborn", "off"); }, kDeadline);
  CHECK(f.value("stubborn", "exitCode") == "-9");
  CHECK(processGone(pid));
  const auto seen = f.states.entries();
  REQUIRE(seen.size() >= 2);
  CHECK(seen[seen.size() - 2] == "stubborn stopping");
}

TEST_CASE("peis-init stops its components when it stops, and nothing else", "[integration]") {
  LauncherFixture f("init-exit");
  f.file("sleeper", "name: sleeper\nexecutable: sleep\narguments: ['600']\nstart: on\n");
  Process bystander({"/bin/sleep", "600"});  // started by the test, not by the launcher
  f.start();
  StateReport report([&] { return f.report(); });
  REQUIRE_WAIT([&] { return f.reached("sleeper", "on"); }, kDeadline);
  const pid_t pid = std::stoi(f.value("sleeper", "pid"));
  f.launcher->kill(SIGTERM);
  const auto status = f.launcher->wait(kDeadline);
  REQUIRE(status);
  CHECK(*status == 0);
  CHECK(f.launcher->err().find("stopping the components") != std::string::npos);
  CHECK(processGone(pid));
  CHECK(bystander.running());
}

TEST_CASE("a killed peis-init takes its components along", "[fault]") {
  LauncherFixture f("init-killed");
  f.file("sleeper", "name: sleeper\nexecutable: sleep\narguments: ['600']\nstart: on\n");
  f.start();
  StateReport report([&] { return f.report(); });
  REQUIRE_WAIT([&] { return f.reached("sleeper", "on"); }, kDeadline);
  const pid_t pid = std::stoi(f.value("sleeper", "pid"));
  f.launcher->kill(SIGKILL);
  REQUIRE(f.launcher->wait(kDeadline));
  REQUIRE_WAIT([&] { return processGone(pid); }, kDeadline);
}

// Runs a program that ends by itself (peis-init with bad files, --check).
CliResult runToEnd(std::vector<std::string> argv, const Process::Environment& env = {}) {
  Process p(std::move(argv), env);
  const auto status = p.wait(kDeadline);
  INFO(p.describe());
  REQUIRE(status);
  return CliResult{*status, p.out(), p.err()};
}

TEST_CASE("peis-init refuses broken and unknown component files with file:line", "[unit]") {
  TempDir dir("launcher-bad");
  dir.write("good.yaml", "name: good\nexecutable: sh\n");
  SECTION("broken YAML") {
    dir.write("broken.yaml", "name: broken\nexecutable: sh\narguments: [a, b\n");
    const auto r = runToEnd({PEIS_INIT_PATH, dir.path.string()});
    CHECK(r.status == 2);
    CHECK(r.err.find(dir.file("broken.yaml") + ":4: not valid YAML") != std::string::npos);
  }
  SECTION("an unknown key") {
    dir.write("typo.yaml", "name: typo\nexecutable: sh\nargs: [a]\n");
    const auto r = runToEnd({PEIS_INIT_PATH, dir.path.string()});
    CHECK(r.status == 2);
    CHECK(r.err.find(dir.file("typo.yaml") + ":3: unknown key 'args' in the component file") !=
          std::string::npos);
  }
  SECTION("--check lists valid files") {
    const auto r = runToEnd({PEIS_INIT_PATH, dir.path.string(), "--check"});
    CHECK(r.status == 0);
    CHECK(r.out == "good: sh (" + dir.file("good.yaml") + "), start off, restart on-failure\n");
  }
  SECTION("`peis init` runs peis-init, as git runs git-FOO") {
    const std::string initDir = std::filesystem::path(PEIS_INIT_PATH).parent_path();
    const auto r = runToEnd({PEIS_CLI_PATH, "init", dir.path.string(), "--check"},
                            {{"PEIS_EXEC_PATH", initDir}});
    CHECK(r.status == 0);
    CHECK(r.out.find("good: sh") == 0);
  }
  SECTION("a missing folder and bad options") {
    auto r = runToEnd({PEIS_INIT_PATH, dir.file("nope")});
    CHECK(r.status == 2);
    CHECK(r.err.find("not a folder of component files") != std::string::npos);
    r = runToEnd({PEIS_INIT_PATH});
    CHECK(r.status == 2);
    CHECK(r.err == "peis-init: FOLDER is missing (see --help)\n");
    r = runToEnd({PEIS_INIT_PATH, dir.path.string(), "--bogus"});
    CHECK(r.status == 2);
    CHECK(r.err == "peis-init: unknown option --bogus (see --help)\n");
    peis::Options taken;
    taken.discovery = false;
    peis::Kernel holder(taken);  // holds a TCP port
    r = runToEnd({PEIS_INIT_PATH, dir.path.string(), "--peis-port", std::to_string(holder.port())});
    CHECK(r.status == 2);
    CHECK(r.err.find("peis-init: ") == 0);
  }
}
