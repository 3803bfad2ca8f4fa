// peis-scenario as a program: small scenarios run end to end (every PEIS
// its own process over loopback), faults injected (stop, kill, a radio
// cut), and bad input — a program that does not exist, a broken file, unknown
// keys, a PEIS that fails to start, a condition that can never hold, a run
// interrupted with SIGINT (every process it started gone, the trace kept).
#include <signal.h>
#include <sqlite3.h>

#include <catch2/catch.hpp>
#include <cerrno>
#include <filesystem>
#include <regex>
#include <set>

#include "support/process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

using Catch::Matchers::Contains;
using peis::test::Process;
using peis::test::TempDir;
using peis::test::waitFor;
using namespace std::chrono_literals;

namespace {

struct Run {
  int status = -1;
  std::string out, err;
  std::string all() const { return out + "\n--- stderr ---\n" + err; }
};

std::vector<std::string> scenarioArgs(std::vector<std::string> args) {
  args.insert(args.begin(), PEIS_SCENARIO_PATH);
  return args;
}

Run runScenario(std::vector<std::string> args, std::chrono::seconds deadline = 180s) {
  Process p(scenarioArgs(std::move(args)));
  const auto status = p.wait(deadline);
  INFO(p.describe());
  REQUIRE(status.has_value());
  return Run{*status, p.out(), p.err()};
}

// The pids of the processes the runner started, from its timeline.
std::set<pid_t> startedPids(const std::string& out) {
  static const std::regex started(R"(started .*, pid (\d+))");
  std::set<pid_t> pids;
  for (auto it = std::sregex_iterator(out.begin(), out.end(), started);
       it != std::sregex_iterator(); ++it)
    pids.insert(static_cast<pid_t>(std::stol((*it)[1])));
  return pids;
}

bool gone(pid_t pid) { return ::kill(pid, 0) != 0 && errno == ESRCH; }

std::string query(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  std::string value = "<none>";
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr) == SQLITE_OK &&
        sqlite3_step(s) == SQLITE_ROW && sqlite3_column_text(s, 0))
      value = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
    sqlite3_finalize(s);
  }
  sqlite3_close(db);
  return value;
}

// Two `peis node` PEIS and a third to be killed.
const char* kNodes = R"(name: nodes
speed: 1
deadline: 40
peis:
  - name: alpha
    program: peis
    options: [node, --peis-set-tuple, greeting=hello]
  - name: beta
    program: peis
    options: [node]
goals:
  - at: 0.5
    set: beta.request
    value: from the scenario in {ecology}
timeline:
  - tuple: beta.request
    say: beta was asked ({value})
  - tuple: alpha.greeting
    say: alpha says {value}
success:
  - name: alpha greets
    tuple: alpha.greeting
    equals: hello
  - name: beta was asked
    tuple: beta.request
    matches: "^from the scenario in scenario-nodes-"
    after: alpha greets
)";

}  // namespace

TEST_CASE("scenario run: two PEIS and a goal and the trace end to end", "[integration][scenario]") {
  TempDir dir("scenario-run");
  const std::string file = dir.write("nodes.yaml", kNodes);
  const std::string trace = dir.file("nodes.sqlite");
  const Run run = runScenario({"run", file, "--trace", trace, "--picture", ""});
  INFO(run.all());
  REQUIRE(run.status == 0);
  CHECK_THAT(run.out, Contains("alpha says hello"));
  CHECK_THAT(run.out, Contains("beta was asked (from the scenario in scenario-nodes-"));
  CHECK_THAT(run.out, Contains("condition 'beta was asked' holds"));
  CHECK_THAT(run.out, Contains("SUCCESS: every success condition held"));
  CHECK_THAT(run.out, Contains("stopped the 2 processes it started"));
  for (const pid_t pid : startedPids(run.out)) CHECK(gone(pid));
  CHECK(query(trace, "SELECT value FROM recording WHERE key = 'result'") == "success");
  CHECK(query(trace,
              "SELECT count(*) > 0 FROM tuple_events WHERE key = 'greeting' AND data = "
              "CAST('hello' AS BLOB)") == "1");
  CHECK(query(trace, "SELECT count(*) FROM tuple_events WHERE key = 'request'") == "1");
  CHECK(query(trace, "SELECT pid > 0 FROM peis WHERE name = 'alpha'") == "1");
  CHECK(query(trace, "SELECT count(*) FROM conditions WHERE held = 1") == "2");
  CHECK(query(trace, "SELECT count(*) > 3 FROM timeline") == "1");
}

TEST_CASE("scenario run: a stopped PEIS leaves and comes back while a killed one stays dead",
          "[fault][scenario]") {
  TempDir dir("scenario-faults");
  const std::string file = dir.write("faults.yaml", R"(name: faults
deadline: 60
peis:
  - {name: alpha, program: peis, options: [node]}
  - {name: beta, program: peis, options: [node]}
  - {name: gamma, program: peis, options: [node]}
  - {name: delta, program: peis, options: [node]}
goals:
  - {at: 8, set: alpha.after, value: back}
  - {at: 3, set: beta.go, value: "yes"}
faults:
  - {at: 1, stop: alpha, for: 4}
  - {at: 0.5, kill: delta, after: beta is told}
success:
  - {name: alpha answers after its stop, tuple: alpha.after, equals: back}
  - {name: beta is told, tuple: beta.go, equals: "yes"}
)");
  const Run run = runScenario({"run", file, "--inject", "kill gamma at 0.5", "--trace",
                               dir.file("t.sqlite"), "--picture", ""});
  INFO(run.all());
  REQUIRE(run.status == 0);
  CHECK_THAT(run.out, Contains("FAULT: kill -9"));
  CHECK_THAT(run.out, Contains("exited: killed by SIGKILL"));
  CHECK_THAT(run.out, Contains("FAULT: stopped with SIGSTOP for 4.0 s"));
  CHECK_THAT(run.out, Contains("alpha") && Contains("left the ecology"));
  CHECK_THAT(run.out, Contains("resumed with SIGCONT"));
  // delta's kill waits for the condition it comes after (at 3), not only its time (0.5).
  const std::regex deltaKilled(R"(([0-9.]+) s  delta +FAULT: kill -9)");
  std::smatch killed;
  REQUIRE(std::regex_search(run.out, killed, deltaKilled));
  CHECK(std::stod(killed[1]) >= 3.0);
  const auto told = run.out.find("condition 'beta is told' holds");
  REQUIRE(told != std::string::npos);
  CHECK(told < static_cast<std::size_t>(killed.position(0)));
  // alpha came back: it joined twice.
  const std::regex joined(R"(alpha +joined the ecology)");
  CHECK(std::distance(std::sregex_iterator(run.out.begin(), run.out.end(), joined),
                      std::sregex_iterator()) == 2);
  for (const pid_t pid : startedPids(run.out)) CHECK(gone(pid));
}

TEST_CASE("scenario run: tiny nodes on the radio with the bridge's link cut and restored",
          "[fault][scenario]") {
  TempDir dir("scenario-radio");
  const std::string keys = std::string(PEIS_SOURCE_DIR) + "/bridge/keys.yaml";
  const std::string file = dir.write("radio.yaml", R"(name: radio
deadline: 60
peis:
  - name: HomePC
    program: peis-tinybridge
    options: [--link, "{radio}", --keys, ")" + keys + R"(", --registry, "{dir}/keys.sqlite"]
  - {name: plant, id: 3, tiny: plant, env: {TINY_LIGHT: "900"}}
  - {name: blind, id: 4, tiny: blind}
goals:
  - {at: 16, set: blind.Note, value: "5"}
faults:
  - {at: 1, cut: HomePC, for: 8}
timeline:
  - {tuple: plant.TiltValue, say: "too much sun: the plant asks the blind to close", when: {equals: "0"}}
  - {tuple: blind.BlindPosition, say: "the blind is at {value}"}
success:
  - {name: the blind closed, tuple: blind.BlindPosition, equals: "0"}
  - {name: the blind took a write after the cut, tuple: blind.Note, equals: "5"}
)");
  const Run run = runScenario({"run", file, "--trace", dir.file("t.sqlite"), "--picture", ""});
  INFO(run.all());
  REQUIRE(run.status == 0);
  CHECK_THAT(run.out, Contains("too much sun: the plant asks the blind to close"));
  CHECK_THAT(run.out, Contains("the blind is at 0"));
  // Cut off the radio, the bridge stops hearing the nodes: their PEIS leave
  // the ecology, and come back when the link is restored.
  const auto cut = run.out.find("FAULT: radio link cut for 8.0 s");
  const auto left = run.out.find("left the ecology (PEIS 4)");
  const auto restored = run.out.find("radio link restored");
  REQUIRE(cut != std::string::npos);
  REQUIRE(left != std::string::npos);
  REQUIRE(restored != std::string::npos);
  CHECK(cut < left);
  CHECK(left < restored);
  const std::regex rejoined(R"(blind +joined the ecology as PEIS 4)");
  const auto joins = std::distance(std::sregex_iterator(run.out.begin(), run.out.end(), rejoined),
                                   std::sregex_iterator());
  CHECK(joins == 2);
}

TEST_CASE("scenario: bad input is a clear error and nothing is left running", "[fault][scenario]") {
  TempDir dir("scenario-bad");
  SECTION("a program that does not exist") {
    const auto file = dir.write("p.yaml",
                                "name: p\ndeadline: 5\npeis:\n  - {name: a, program: "
                                "peis-nonexistent}\nsuccess:\n  - {name: c, tuple: "
                                "a.x, equals: '1'}\n");
    const Run run = runScenario({"run", file});
    CHECK(run.status == 2);
    CHECK_THAT(run.err, Contains(file + ":4: unknown program 'peis-nonexistent'"));
    CHECK_THAT(run.out, !Contains("started"));
    const Run check = runScenario({"check", file});
    CHECK(check.status == 1);
    CHECK_THAT(check.err, Contains("unknown program 'peis-nonexistent'"));
  }
  SECTION("a broken file and unknown keys") {
    const auto broken = dir.write("b.yaml", "name: b\npeis: [\n  {name: a\n");
    const Run run = runScenario({"run", broken});
    CHECK(run.status == 2);
    CHECK_THAT(run.err, Contains(broken + ":") && Contains("broken YAML"));
    const auto unknown = dir.write("u.yaml", "name: u\nsucces:\n  - {name: c}\n");
    const Run check = runScenario({"check", unknown});
    CHECK(check.status == 1);
    CHECK_THAT(check.err, Contains(unknown + ":2: unknown key 'succes' in the scenario"));
    CHECK(runScenario({"check"}).status == 2);
    CHECK(runScenario({"run", unknown, "--speed", "1000"}).status == 2);
    CHECK(runScenario({"walk", unknown}).status == 2);
    CHECK(runScenario({"check", dir.file("missing.yaml")}).status == 1);
  }
  SECTION("a PEIS that fails to start") {
    const auto file = dir.write("s.yaml", R"(name: s
deadline: 10
peis:
  - {name: alpha, program: peis, options: [node]}
  - {name: broken, program: peis, options: [node, --no-such-flag]}
success:
  - {name: c, tuple: alpha.x, equals: "1"}
)");
    const Run run = runScenario({"run", file, "--picture", "", "--trace", dir.file("t.sqlite")});
    INFO(run.all());
    CHECK(run.status == 3);
    CHECK_THAT(run.out, Contains("FAILED to start: peis ended with exit status 2 before joining"));
    CHECK_THAT(run.err, Contains("no-such-flag"));  // the end of its log
    const auto pids = startedPids(run.out);
    CHECK(pids.size() == 2);
    for (const pid_t pid : pids) CHECK(gone(pid));
  }
  SECTION("a success condition that can never hold") {
    const auto file = dir.write("n.yaml", R"(name: never
peis:
  - {name: alpha, program: peis, options: [node, --peis-set-tuple, greeting=hello]}
success:
  - {name: alpha says goodbye, tuple: alpha.greeting, equals: goodbye, by: 8}
)");
    const Run run = runScenario({"run", file, "--picture", "", "--trace", dir.file("t.sqlite")});
    INFO(run.all());
    CHECK(run.status == 1);
    CHECK_THAT(run.out, Contains("FAILED: condition 'alpha says goodbye' did not hold by 8.0 s "
                                 "(last seen: 'hello')"));
    CHECK_THAT(run.out, Contains("NOT HELD  alpha says goodbye"));
    for (const pid_t pid : startedPids(run.out)) CHECK(gone(pid));
    CHECK(
        query(dir.file("t.sqlite"), "SELECT value FROM recording WHERE key = 'failed_condition'") ==
        "alpha says goodbye");
  }
}

TEST_CASE("scenario run: interrupted by SIGINT it stops everything and keeps the trace",
          "[fault][scenario]") {
  TempDir dir("scenario-sigint");
  const std::string file = dir.write("long.yaml", R"(name: long
peis:
  - {name: alpha, program: peis, options: [node, --peis-set-tuple, greeting=hello]}
  - {name: beta, program: peis, options: [node]}
timeline:
  - {tuple: alpha.greeting, say: "alpha says {value}"}
success:
  - {name: forever, tuple: alpha.greeting, equals: never, by: 600}
)");
  const std::string trace = dir.file("t.sqlite");
  Process runner(scenarioArgs({"run", file, "--trace", trace, "--picture", ""}));
  REQUIRE(
      waitFor([&] { return runner.out().find("scenario time starts") != std::string::npos; }, 60s));
  // Tuples reach the runner (and its trace) before the interrupt.
  REQUIRE(waitFor([&] { return runner.out().find("alpha says hello") != std::string::npos; }, 30s));
  const auto pids = startedPids(runner.out());
  REQUIRE(pids.size() == 2);
  runner.kill(SIGINT);
  const auto status = runner.wait(30s);
  INFO(runner.describe());
  REQUIRE(status == std::optional<int>(130));
  CHECK_THAT(runner.out(), Contains("interrupted by SIGINT: stopping everything"));
  for (const pid_t pid : pids) CHECK(gone(pid));
  CHECK(query(trace, "SELECT value FROM recording WHERE key = 'result'") == "interrupted");
  CHECK(query(trace, "SELECT count(*) > 0 FROM tuple_events") == "1");
}

TEST_CASE("scenario: peis scenario runs peis-scenario", "[integration][scenario]") {
  TempDir dir("scenario-cli");
  const std::string file = dir.write("nodes.yaml", kNodes);
  const std::string scenarioDir = std::filesystem::path(PEIS_SCENARIO_PATH).parent_path();
  Process peis({PEIS_CLI_PATH, "scenario", "check", file}, {{"PEIS_EXEC_PATH", scenarioDir}});
  REQUIRE(peis.wait(30s) == std::optional<int>(0));
  CHECK_THAT(peis.out(),
             Contains(file + ": valid (2 PEIS, 1 goal, 0 faults, 2 success conditions)"));
}
