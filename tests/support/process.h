// Test helper: a child process the test starts, owns and ends. The child's
// stdout and stderr go to temporary files the test can read back at any
// time. The destructor SIGKILLs the child (by its pid, nothing else) if it
// is still running and reaps it, so a failing test leaves nothing behind;
// the child also gets SIGKILL if the thread that started it dies.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace peis::test {

class Process {
 public:
  using Environment = std::vector<std::pair<std::string, std::string>>;

  // Starts argv[0] (a path, not looked up in PATH) with argv, the test's
  // environment plus `extraEnvironment` (which wins on equal names).
  // Throws std::runtime_error if it cannot start.
  explicit Process(std::vector<std::string> argv, const Environment& extraEnvironment = {});
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;
  ~Process();

  pid_t pid() const { return pid_; }
  const std::vector<std::string>& argv() const { return argv_; }

  // Sends `signal` to the child, unless it has been reaped already.
  void kill(int signal);
  // Waits up to `deadline` for the child to end. Returns its exit code, or
  // -N when signal N ended it; nullopt if it is still running.
  std::optional<int> wait(std::chrono::milliseconds deadline);
  // True while the child has not ended (reaps it if it has).
  bool running();

  // Everything the child wrote so far.
  std::string out() const;
  std::string err() const;
  // argv, exit state, stdout and stderr: for failure messages.
  std::string describe();

 private:
  bool reap(bool block);

  std::vector<std::string> argv_;
  pid_t pid_ = -1;
  std::optional<int> status_;
  std::string outPath_, errPath_;
};

// The `peis` command-line tool built with these tests.
std::string peisCliPath();
// argv for `peis ARGS... --peis-ecology ECOLOGY`.
std::vector<std::string> cliArgs(const std::string& ecology, std::vector<std::string> args);

// An ecology name of its own for one test: "it-<tag>-<pid>", so tests that
// run in parallel (or in other test programs) never meet.
std::string uniqueEcology(const std::string& tag);

}  // namespace peis::test
