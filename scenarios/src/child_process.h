// The processes a scenario run starts. Each child runs in a process group
// of its own (so a terminal's Ctrl-C reaches the runner only, which then
// stops the children in order), writes stdout and stderr to its log file,
// and gets SIGKILL if the runner dies. Signals go to the child's group, whose
// id is the child's pid: the runner never signals anything it did not start.
#pragma once

#include <sys/types.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace peis::scenario {

class ChildProcess {
 public:
  using Environment = std::vector<std::pair<std::string, std::string>>;

  // Starts argv[0] (a path) with this process's environment plus `extra`
  // (which wins). Throws std::runtime_error when it cannot be started, with
  // the reason exec gave ("No such file or directory").
  ChildProcess(std::vector<std::string> argv, const Environment& extra, const std::string& logPath);
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  // Kills the group and reaps the child if it still runs.
  ~ChildProcess();

  pid_t pid() const { return pid_; }
  const std::string& logPath() const { return logPath_; }

  // Sends `signal` to the child's process group unless the child was reaped.
  void signal(int signal);
  // Reaps the child if it ended; true while it runs.
  bool running();
  // Its exit: "exit status N" or "killed by SIGKILL"; empty while it runs.
  std::string exitText();
  std::optional<int> exitCode();  // N, or -signal
  // The last `bytes` of its log.
  std::string logTail(std::size_t bytes = 2000) const;

 private:
  pid_t pid_ = -1;
  std::optional<int> status_;  // raw waitpid status
  std::string logPath_;
};

}  // namespace peis::scenario
