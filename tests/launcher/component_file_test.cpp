// The launcher's component files: every field, the defaults, and the
// errors (file:line and the problem) for broken YAML, unknown keys and bad
// values; a folder with a broken file reports it with the others' problems.
#include "launcher/component_file.h"

#include <catch2/catch.hpp>

#include "peis/error.h"
#include "support/error_matchers.h"
#include "support/temp_dir.h"

using peis::launcher::ComponentFile;
using peis::launcher::parseComponentFile;
using peis::launcher::RestartPolicy;
using namespace std::chrono_literals;

namespace {

std::string problemOf(const std::string& yaml) {
  try {
    parseComponentFile(yaml, "c.yaml", "/etc/peis");
  } catch (const peis::Error& e) {
    CHECK(e.code() == peis::ErrorCode::InvalidConfig);
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("a component file with every field", "[unit]") {
  const auto c = parseComponentFile(R"(
name: tracker
executable: bin/peis-tracker
arguments: [--cameras, 2]
peis:
  name: ceiling
  id: 20
  connect: [a:1, b:2]
  set-tuple: {mode: fast}
  no-discovery: yes
environment: {PEIS_LOG: debug, LANG: C}
working-directory: run
start: on
restart: {policy: always, max-restarts: 3, backoff: 0.5, max-backoff: 4, reset-after: 60}
stop-grace: 2.5
output-lines: 5
descriptor: tracker-descriptor.yaml
)",
                                    "tracker.yaml", "/etc/peis");
  CHECK(c.name == "tracker");
  CHECK(c.file == "tracker.yaml");
  CHECK(c.executable == "/etc/peis/bin/peis-tracker");
  CHECK(c.executableLine == 3);
  CHECK(c.arguments == std::vector<std::string>{"--cameras", "2"});
  CHECK(c.peisFlags == std::vector<std::string>{"--peis-name", "ceiling", "--peis-id", "20",
                                                "--peis-connect", "a:1", "--peis-connect", "b:2",
                                                "--peis-set-tuple", "mode=fast",
                                                "--peis-no-discovery"});
  CHECK(c.peisName == "ceiling");
  REQUIRE(c.environment.size() == 2);
  CHECK(c.environment[0] == std::make_pair(std::string("PEIS_LOG"), std::string("debug")));
  CHECK(c.workingDirectory == "/etc/peis/run");
  CHECK(c.startOn);
  CHECK(c.restart.policy == RestartPolicy::Always);
  CHECK(c.restart.maxRestarts == 3);
  CHECK(c.restart.backoff == 500ms);
  CHECK(c.restart.maxBackoff == 4s);
  CHECK(c.restart.resetAfter == 60s);
  CHECK(c.restart.stopGrace == 2500ms);
  CHECK(c.outputLines == 5);
  CHECK(c.descriptor == "/etc/peis/tracker-descriptor.yaml");
  CHECK(peis::launcher::commandLine(c, "/x/peis-tracker") ==
        std::vector<std::string>{"/x/peis-tracker", "--peis-name", "ceiling", "--peis-id", "20",
                                 "--peis-connect", "a:1", "--peis-connect", "b:2",
                                 "--peis-set-tuple", "mode=fast", "--peis-no-discovery",
                                 "--cameras", "2"});
}

TEST_CASE("the defaults of a component file", "[unit]") {
  const auto c =
      parseComponentFile("name: lamp\nexecutable: peis-example-lamp\n", "l.yaml", "/srv/c");
  CHECK(c.executable == "peis-example-lamp");  // looked up on PATH when started
  CHECK(c.arguments.empty());
  CHECK(c.peisFlags.empty());
  CHECK(c.peisName.empty());
  CHECK(c.workingDirectory == "/srv/c");
  CHECK_FALSE(c.startOn);
  CHECK(c.restart.policy == RestartPolicy::OnFailure);
  CHECK(c.restart.maxRestarts == 5);
  CHECK(c.restart.backoff == 1s);
  CHECK(c.restart.maxBackoff == 30s);
  CHECK(c.restart.resetAfter == 10s);
  CHECK(c.restart.stopGrace == 5s);
  CHECK(c.outputLines == 20);
  CHECK(c.descriptor.empty());
}

TEST_CASE("broken component files name the file, the line and the problem", "[unit]") {
  CHECK(problemOf("name: a\nexecutable: [x\n") ==
        "c.yaml:3: not valid YAML: end of sequence flow not found");
  CHECK(problemOf("name: a\nexecutable: x\nrestrat: {policy: never}\n") ==
        "c.yaml:3: unknown key 'restrat' in the component file (known: name, executable, "
        "arguments, peis, environment, working-directory, start, restart, stop-grace, "
        "output-lines, descriptor)");
  CHECK(problemOf("name: a\nexecutable: x\nrestart: {polcy: never}\n") ==
        "c.yaml:3: unknown key 'polcy' in restart (known: policy, max-restarts, backoff, "
        "max-backoff, reset-after)");
  CHECK(problemOf("name: a\nexecutable: x\npeis: {nmae: x}\n") ==
        "c.yaml:3: unknown key 'nmae' in peis (known: id, name, port, connect, set-tuple, "
        "ecology, discovery-port, liveness-ms, max-data, no-discovery)");
  CHECK(problemOf("executable: x\n") == "c.yaml:1: the component file needs 'name'");
  CHECK(problemOf("name: a\n") == "c.yaml:1: the component file needs 'executable'");
  CHECK(problemOf("name: a.b\nexecutable: x\n") ==
        "c.yaml:1: name 'a.b' must be one key part (1..64 bytes, no '.', '*', '=', spaces)");
  CHECK(problemOf("- name: a\n") == "c.yaml:1: a component file must be a mapping");
  CHECK(problemOf("name: a\nexecutable: x\nstart: maybe\n") ==
        "c.yaml:3: start must be on or off, not 'maybe'");
  CHECK(problemOf("name: a\nexecutable: x\nrestart: {policy: sometimes}\n") ==
        "c.yaml:3: restart policy must be never, on-failure or always, not 'sometimes'");
  CHECK(problemOf("name: a\nexecutable: x\nstop-grace: -1\n") ==
        "c.yaml:3: stop-grace (seconds) must be in 0..86400, not -1");
  CHECK(problemOf("name: a\nexecutable: x\nrestart: {backoff: 10, max-backoff: 1}\n") ==
        "c.yaml:3: max-backoff is less than backoff");
  CHECK(problemOf("name: a\nexecutable: x\npeis: {id: 0}\n") ==
        "c.yaml:3: peis: --peis-id: '0' is not an id in 1..2147483647");
  CHECK(problemOf("name: a\nexecutable: x\narguments: -x\n") ==
        "c.yaml:3: arguments must be a list");
  CHECK(problemOf("name: a\nexecutable: x\nenvironment: [A]\n") ==
        "c.yaml:3: environment must be a mapping of NAME: value");
}

TEST_CASE("a folder of component files: all problems at once, duplicates refused", "[unit]") {
  peis::test::TempDir dir("launcher");
  dir.write("a.yaml", "name: a\nexecutable: /bin/true\n");
  dir.write("b.yaml", "name: a\nexecutable: /bin/false\n");
  dir.write("c.yml", "name: c\nexecutable: /bin/true\nbogus: 1\n");
  dir.write("notes.txt", "not a component file");
  try {
    peis::launcher::loadComponentFolder(dir.path.string());
    FAIL("no error");
  } catch (const peis::Error& e) {
    const std::string what = e.what();
    CHECK(what == dir.file("b.yaml") + ": component 'a' is also defined in " + dir.file("a.yaml") +
                      "\n" + dir.file("c.yml") +
                      ":3: unknown key 'bogus' in the component file (known: name, executable, "
                      "arguments, peis, environment, working-directory, start, restart, "
                      "stop-grace, output-lines, descriptor)");
  }
  std::filesystem::remove(dir.file("b.yaml"));
  std::filesystem::remove(dir.file("c.yml"));
  const auto loaded = peis::launcher::loadComponentFolder(dir.path.string());
  REQUIRE(loaded.size() == 1);
  CHECK(loaded[0].name == "a");
  CHECK_THROWS_WITH(peis::launcher::loadComponentFolder(dir.file("nope")),
                    dir.file("nope") + ": not a folder of component files");
}

TEST_CASE("executables are found on PATH or as paths", "[unit]") {
  CHECK(peis::launcher::resolveExecutable("sh", "/nonexistent:/bin:/usr/bin") == "/bin/sh");
  CHECK(peis::launcher::resolveExecutable("no-such-program-here", "/bin:/usr/bin").empty());
  CHECK(peis::launcher::resolveExecutable("/bin/sh", "") == "/bin/sh");
  CHECK(peis::launcher::resolveExecutable("/etc/passwd", "").empty());  // not executable
  CHECK(peis::launcher::resolveExecutable("/bin", "").empty());         // a folder
}
