// The processes of a run; see child_process.h.
#include "child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

extern char** environ;

namespace peis::scenario {

ChildProcess::ChildProcess(std::vector<std::string> argv, const Environment& extra,
                           const std::string& logPath)
    : logPath_(logPath) {
  if (argv.empty()) throw std::invalid_argument("ChildProcess needs a program");
  // Everything is prepared before fork(): the runner has threads, so the
  // child may only make async-signal-safe calls until exec.
  std::vector<char*> args;
  for (auto& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  std::set<std::string> overridden;
  std::vector<std::string> envText;
  for (const auto& [name, value] : extra) {
    overridden.insert(name);
    envText.push_back(name + "=" + value);
  }
  for (char** e = environ; e && *e; ++e) {
    const std::string text = *e;
    if (!overridden.count(text.substr(0, text.find('=')))) envText.push_back(text);
  }
  std::vector<char*> env;
  for (auto& t : envText) env.push_back(t.data());
  env.push_back(nullptr);

  const int logFd = ::open(logPath.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  const int nullFd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  int report[2] = {-1, -1};  // exec's errno, if exec fails
  if (logFd < 0 || nullFd < 0 || ::pipe2(report, O_CLOEXEC) != 0) {
    const int e = errno;
    for (int fd : {logFd, nullFd, report[0], report[1]})
      if (fd >= 0) ::close(fd);
    throw std::runtime_error("cannot prepare " + argv[0] + " (log " + logPath +
                             "): " + std::strerror(e));
  }
  const pid_t parent = ::getpid();
  pid_ = ::fork();
  if (pid_ == 0) {
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) _exit(127);
    ::dup2(nullFd, 0);
    ::dup2(logFd, 1);
    ::dup2(logFd, 2);
    const int keep = report[1];
    // Close everything but stdio and the report pipe (CLOEXEC: gone at exec).
    for (int fd = 3; fd < 1024; ++fd)
      if (fd != keep) ::close(fd);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    for (int s : {SIGPIPE, SIGINT, SIGTERM, SIGCHLD}) ::sigaction(s, &dfl, nullptr);
    ::execve(args[0], args.data(), env.data());
    const int e = errno;
    (void)!::write(keep, &e, sizeof e);
    _exit(127);
  }
  const int forkErrno = errno;
  ::close(logFd);
  ::close(nullFd);
  ::close(report[1]);
  if (pid_ < 0) {
    ::close(report[0]);
    throw std::runtime_error("cannot fork for " + argv[0] + ": " + std::strerror(forkErrno));
  }
  // Also from here, so a signal sent at once reaches the group.
  ::setpgid(pid_, pid_);
  int execErrno = 0;
  ssize_t n;
  do {
    n = ::read(report[0], &execErrno, sizeof execErrno);
  } while (n < 0 && errno == EINTR);
  ::close(report[0]);
  if (n == static_cast<ssize_t>(sizeof execErrno)) {
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    throw std::runtime_error("cannot run " + argv[0] + ": " + std::strerror(execErrno));
  }
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && !status_) {
    ::kill(-pid_, SIGKILL);
    ::kill(pid_, SIGKILL);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
  }
}

void ChildProcess::signal(int sig) {
  if (pid_ <= 0 || !running()) return;
  if (::kill(-pid_, sig) != 0) ::kill(pid_, sig);
}

bool ChildProcess::running() {
  if (pid_ <= 0 || status_) return false;
  int status = 0;
  const pid_t r = ::waitpid(pid_, &status, WNOHANG);
  if (r == pid_ && (WIFEXITED(status) || WIFSIGNALED(status))) {
    status_ = status;
    return false;
  }
  return true;
}

std::optional<int> ChildProcess::exitCode() {
  if (running() || !status_) return std::nullopt;
  if (WIFEXITED(*status_)) return WEXITSTATUS(*status_);
  return -WTERMSIG(*status_);
}

std::string ChildProcess::exitText() {
  const auto code = exitCode();
  if (!code) return "";
  if (*code >= 0) return "exit status " + std::to_string(*code);
  const char* name = sigabbrev_np(-*code);
  return std::string("killed by SIG") + (name ? name : std::to_string(-*code).c_str());
}

std::string ChildProcess::logTail(std::size_t bytes) const {
  std::ifstream in(logPath_, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  const std::string all = text.str();
  return all.size() > bytes ? "…" + all.substr(all.size() - bytes) : all;
}

}  // namespace peis::scenario
