// Starting and watching launched programs (see child_processes.h).
#include "launcher/child_processes.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <variant>

namespace peis::launcher {
namespace {

int pidfdOpen(pid_t pid) { return static_cast<int>(::syscall(SYS_pidfd_open, pid, 0)); }

int pidfdSignal(int pidfd, int signal) {
  return static_cast<int>(::syscall(SYS_pidfd_send_signal, pidfd, signal, nullptr, 0));
}

void closeFd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

int exitCodeOf(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return -WTERMSIG(status);
  return -1;
}

// What the child reports through its close-on-exec pipe when exec fails.
struct ChildFailure {
  int stage;  // 0: chdir, 1: exec, 2: setup
  int error;
};

// Runs in the forked child: only async-signal-safe calls until execve.
[[noreturn]] void becomeProgram(const RunRequest& request, char* const* argv, char* const* envp,
                                int devNull, int out, int err, int report, pid_t parent) {
  const auto fail = [report](int stage) {
    const ChildFailure failure{stage, errno};
    [[maybe_unused]] auto n = ::write(report, &failure, sizeof failure);
    ::_exit(127);
  };
  ::setpgid(0, 0);
  if (::prctl(PR_SET_PDEATHSIG, SIGTERM) != 0) fail(2);
  if (::getppid() != parent) ::_exit(1);  // the launcher is already gone
  struct sigaction fallback {};
  fallback.sa_handler = SIG_DFL;
  for (int sig = 1; sig < NSIG; ++sig) ::sigaction(sig, &fallback, nullptr);
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  if (::dup2(devNull, 0) < 0 || ::dup2(out, 1) < 0 || ::dup2(err, 2) < 0) fail(2);
  if (::chdir(request.workingDirectory.c_str()) != 0) fail(0);
  // Nothing else of the launcher (its sockets, its files) reaches the program.
  if (::close_range(3, ~0U, CLOSE_RANGE_CLOEXEC) != 0) {
    for (int fd = 3; fd < 65536; ++fd) ::fcntl(fd, F_SETFD, FD_CLOEXEC);
  }
  ::execve(request.program.c_str(), argv, envp);
  fail(1);
  ::_exit(127);
}

struct Run {
  pid_t pid = -1;
  int pidfd = -1, out = -1, err = -1, log = -1;
};

struct SignalRequest {
  RunId run;
  int signal;
};

}  // namespace

struct ChildProcesses::Impl {
  ChildEvents events;
  int wake[2] = {-1, -1};
  std::mutex mu;
  std::deque<std::variant<RunRequest, SignalRequest>> commands;  // guarded by mu
  bool stopping = false;                                         // guarded by mu
  std::map<RunId, Run> runs;                                     // the watcher thread's only
  std::thread thread;

  void loop();
  void startRun(const RunRequest& request);
  // Reads what the stream has now; false at its end (or on an error).
  bool drain(RunId id, Run& run, int& fd, Stream stream);
  void finish(RunId id, Run& run);
  void killAll();
};

ChildProcesses::ChildProcesses(ChildEvents events) : impl_(std::make_unique<Impl>()) {
  impl_->events = std::move(events);
  if (::pipe2(impl_->wake, O_CLOEXEC | O_NONBLOCK) != 0)
    throw std::runtime_error(std::string("cannot make a pipe: ") + std::strerror(errno));
  impl_->thread = std::thread([this] { impl_->loop(); });
}

ChildProcesses::~ChildProcesses() {
  {
    std::lock_guard lock(impl_->mu);
    impl_->stopping = true;
  }
  [[maybe_unused]] auto n = ::write(impl_->wake[1], "x", 1);
  impl_->thread.join();
  closeFd(impl_->wake[0]);
  closeFd(impl_->wake[1]);
}

void ChildProcesses::start(RunRequest request) {
  {
    std::lock_guard lock(impl_->mu);
    impl_->commands.emplace_back(std::move(request));
  }
  [[maybe_unused]] auto n = ::write(impl_->wake[1], "x", 1);
}

void ChildProcesses::signal(RunId run, int signal) {
  {
    std::lock_guard lock(impl_->mu);
    impl_->commands.emplace_back(SignalRequest{run, signal});
  }
  [[maybe_unused]] auto n = ::write(impl_->wake[1], "x", 1);
}

void ChildProcesses::Impl::startRun(const RunRequest& request) {
  std::vector<std::string> args = request.argv, env = request.environment;
  std::vector<char*> argv, envp;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  for (auto& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  int out[2] = {-1, -1}, err[2] = {-1, -1}, report[2] = {-1, -1};
  const int devNull = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  const auto cleanup = [&] {
    for (int* fd : {&out[0], &out[1], &err[0], &err[1], &report[0], &report[1]}) closeFd(*fd);
    if (devNull >= 0) ::close(devNull);
  };
  if (devNull < 0 || ::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(err, O_CLOEXEC) != 0 ||
      ::pipe2(report, O_CLOEXEC) != 0) {
    const std::string why = std::strerror(errno);
    cleanup();
    events.failed(request.run, "cannot make pipes: " + why);
    return;
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const std::string why = std::strerror(errno);
    cleanup();
    events.failed(request.run, "cannot fork: " + why);
    return;
  }
  if (pid == 0)
    becomeProgram(request, argv.data(), envp.data(), devNull, out[1], err[1], report[1], parent);
  closeFd(out[1]);
  closeFd(err[1]);
  closeFd(report[1]);
  ChildFailure failure{};
  ssize_t got;
  do {
    got = ::read(report[0], &failure, sizeof failure);
  } while (got < 0 && errno == EINTR);
  closeFd(report[0]);
  ::close(devNull);
  if (got == static_cast<ssize_t>(sizeof failure)) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    closeFd(out[0]);
    closeFd(err[0]);
    const std::string reason = std::strerror(failure.error);
    events.failed(request.run,
                  failure.stage == 0
                      ? "cannot enter working directory " + request.workingDirectory + ": " + reason
                  : failure.stage == 1 ? "cannot run " + request.program + ": " + reason
                                       : "cannot set up the process: " + reason);
    return;
  }
  Run run;
  run.pid = pid;
  run.out = out[0];
  run.err = err[0];
  run.pidfd = pidfdOpen(pid);
  if (run.pidfd < 0) {  // cannot watch it: do not leave it running unwatched
    const std::string why = std::strerror(errno);
    ::kill(pid, SIGKILL);  // our own child, not reaped yet: the pid is still its
    int status = 0;
    ::waitpid(pid, &status, 0);
    closeFd(run.out);
    closeFd(run.err);
    events.failed(request.run, "cannot watch the process (pidfd_open: " + why + ")");
    return;
  }
  ::fcntl(run.out, F_SETFL, O_NONBLOCK);
  ::fcntl(run.err, F_SETFL, O_NONBLOCK);
  if (!request.logFile.empty())
    run.log = ::open(request.logFile.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  runs[request.run] = run;
  events.started(request.run, pid);
}

bool ChildProcesses::Impl::drain(RunId id, Run& run, int& fd, Stream stream) {
  char buffer[65536];
  while (fd >= 0) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n > 0) {
      if (run.log >= 0) {
        [[maybe_unused]] auto written = ::write(run.log, buffer, static_cast<size_t>(n));
      }
      events.output(id, stream, std::string_view(buffer, static_cast<size_t>(n)));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    closeFd(fd);  // end of the stream, or an error
  }
  return false;
}

void ChildProcesses::Impl::finish(RunId id, Run& run) {
  drain(id, run, run.out, Stream::Stdout);
  drain(id, run, run.err, Stream::Stderr);
  int status = 0;
  pid_t got;
  do {
    got = ::waitpid(run.pid, &status, 0);
  } while (got < 0 && errno == EINTR);
  // Pipes a grandchild still holds are not waited for.
  closeFd(run.out);
  closeFd(run.err);
  closeFd(run.pidfd);
  closeFd(run.log);
  events.exited(id, got == run.pid ? exitCodeOf(status) : -1);
}

void ChildProcesses::Impl::killAll() {
  for (auto& [id, run] : runs) {
    pidfdSignal(run.pidfd, SIGKILL);
    int status = 0;
    while (::waitpid(run.pid, &status, 0) < 0 && errno == EINTR) {
    }
    closeFd(run.out);
    closeFd(run.err);
    closeFd(run.pidfd);
    closeFd(run.log);
  }
  runs.clear();
}

void ChildProcesses::Impl::loop() {
  std::vector<pollfd> fds;
  std::vector<std::pair<RunId, int>> what;  // per pollfd after the first: run, 0 out 1 err 2 exit
  for (;;) {
    std::deque<std::variant<RunRequest, SignalRequest>> todo;
    {
      std::lock_guard lock(mu);
      if (stopping) break;
      todo.swap(commands);
    }
    for (auto& command : todo) {
      if (auto* request = std::get_if<RunRequest>(&command)) {
        startRun(*request);
      } else {
        const auto& s = std::get<SignalRequest>(command);
        if (auto it = runs.find(s.run); it != runs.end()) pidfdSignal(it->second.pidfd, s.signal);
      }
    }
    fds.assign(1, pollfd{wake[0], POLLIN, 0});
    what.clear();
    for (auto& [id, run] : runs) {
      if (run.out >= 0) fds.push_back({run.out, POLLIN, 0}), what.emplace_back(id, 0);
      if (run.err >= 0) fds.push_back({run.err, POLLIN, 0}), what.emplace_back(id, 1);
      fds.push_back({run.pidfd, POLLIN, 0});
      what.emplace_back(id, 2);
    }
    if (::poll(fds.data(), fds.size(), -1) < 0) continue;  // EINTR
    if (fds[0].revents != 0) {
      char sink[256];
      while (::read(wake[0], sink, sizeof sink) > 0) {
      }
    }
    std::vector<RunId> ended;
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (fds[i].revents == 0) continue;
      const auto [id, kind] = what[i - 1];
      auto it = runs.find(id);
      if (it == runs.end()) continue;
      Run& run = it->second;
      if (kind == 0) drain(id, run, run.out, Stream::Stdout);
      if (kind == 1) drain(id, run, run.err, Stream::Stderr);
      if (kind == 2) ended.push_back(id);
    }
    for (const RunId id : ended) {
      finish(id, runs[id]);
      runs.erase(id);
    }
  }
  killAll();
}

}  // namespace peis::launcher
