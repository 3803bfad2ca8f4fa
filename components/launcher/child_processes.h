// ChildProcesses: starts programs and watches them on a thread of its own,
// so the kernel thread never forks, reads a pipe or waits for a process.
//
// Each run is started with fork+exec on the watcher thread: in a process
// group of its own (a Ctrl-C meant for the launcher does not reach it), with
// SIGTERM as its parent-death signal (a launcher that dies takes its runs
// with it), stdin from /dev/null, stdout and stderr into pipes, no other
// descriptor of the launcher, its environment and working directory. The
// watcher keeps a pidfd per run and polls the pipes and pidfds (no busy loop,
// no SIGCHLD handler): output and exits are reported as they happen. Signals
// go through the pidfd, so only processes this object started are ever
// signalled, and never a recycled pid. The destructor SIGKILLs the runs still
// alive and reaps them.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace peis::launcher {

using RunId = std::uint64_t;

struct RunRequest {
  RunId run = 0;
  std::string program;                   // the file to execute
  std::vector<std::string> argv;         // argv[0] included
  std::vector<std::string> environment;  // NAME=value, the whole environment
  std::string workingDirectory;
  std::string logFile;  // when not empty, all output is appended to it too
};

enum class Stream { Stdout, Stderr };

// Called on the watcher thread, in the order things happened for each run:
// started or failed, then output, then exited.
struct ChildEvents {
  std::function<void(RunId run, pid_t pid)> started;
  std::function<void(RunId run, const std::string& why)> failed;
  std::function<void(RunId run, Stream stream, std::string_view bytes)> output;
  std::function<void(RunId run, int code)> exited;  // >= 0 exit status, -N signal N
};

class ChildProcesses {
 public:
  explicit ChildProcesses(ChildEvents events);
  ~ChildProcesses();
  ChildProcesses(const ChildProcesses&) = delete;
  ChildProcesses& operator=(const ChildProcesses&) = delete;

  // Both return at once; the work is done on the watcher thread.
  void start(RunRequest request);
  void signal(RunId run, int signal);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::launcher
