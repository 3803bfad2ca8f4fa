// Test helper: child processes; see process.h.
#include "support/process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "support/wait_for.h"

extern char** environ;

namespace peis::test {
namespace {

std::string makeTempFile(const char* what) {
  const char* dir = std::getenv("TMPDIR");
  std::string path = std::string(dir && *dir ? dir : "/tmp") + "/peis-test-" + what + "-XXXXXX";
  const int fd = mkostemp(path.data(), O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("mkostemp " + path + ": " + std::strerror(errno));
  ::close(fd);
  return path;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

Process::Process(std::vector<std::string> argv, const Environment& extraEnvironment)
    : argv_(std::move(argv)) {
  if (argv_.empty()) throw std::invalid_argument("Process needs at least argv[0]");
  outPath_ = makeTempFile("out");
  errPath_ = makeTempFile("err");

  // Everything the child needs is prepared before fork(): between fork and
  // exec a multi-threaded parent's child may only make async-signal-safe calls.
  std::vector<char*> args;
  for (auto& arg : argv_) args.push_back(arg.data());
  args.push_back(nullptr);
  std::set<std::string> overridden;
  std::vector<std::string> envStrings;
  for (const auto& [name, value] : extraEnvironment) {
    overridden.insert(name);
    envStrings.push_back(name + "=" + value);
  }
  for (char** entry = environ; entry && *entry; ++entry) {
    const std::string text = *entry;
    if (!overridden.count(text.substr(0, text.find('=')))) envStrings.push_back(text);
  }
  std::vector<char*> env;
  for (auto& text : envStrings) env.push_back(text.data());
  env.push_back(nullptr);

  const int outFd = ::open(outPath_.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  const int errFd = ::open(errPath_.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  const int nullFd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  if (outFd < 0 || errFd < 0 || nullFd < 0) {
    for (int fd : {outFd, errFd, nullFd})
      if (fd >= 0) ::close(fd);
    throw std::runtime_error("cannot open the output files of " + argv_[0]);
  }
  const long maxFd = sysconf(_SC_OPEN_MAX);
  const pid_t parent = getpid();

  pid_ = fork();
  if (pid_ == 0) {
    // Child: end with the parent, take the files as stdio, close every
    // other descriptor (the test's sockets), restore default signals.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);
    dup2(nullFd, 0);
    dup2(outFd, 1);
    dup2(errFd, 2);
    if (syscall(SYS_close_range, 3u, ~0u, 0u) != 0) {
      for (long fd = 3; fd < (maxFd > 0 ? maxFd : 65536); ++fd) ::close(static_cast<int>(fd));
    }
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    sigaction(SIGPIPE, &dfl, nullptr);
    execve(args[0], args.data(), env.data());
    _exit(127);
  }
  const int forkErrno = errno;
  ::close(outFd);
  ::close(errFd);
  ::close(nullFd);
  if (pid_ < 0) {
    throw std::runtime_error("fork for " + argv_[0] + ": " + std::strerror(forkErrno));
  }
}

Process::~Process() {
  if (pid_ > 0 && !status_) {
    ::kill(pid_, SIGKILL);
    reap(true);
  }
  ::unlink(outPath_.c_str());
  ::unlink(errPath_.c_str());
}

bool Process::reap(bool block) {
  if (status_) return true;
  int status = 0;
  pid_t result;
  do {
    result = waitpid(pid_, &status, block ? 0 : WNOHANG);
  } while (result < 0 && errno == EINTR);
  if (result != pid_) return false;
  if (WIFEXITED(status)) {
    status_ = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    status_ = -WTERMSIG(status);
  } else {
    return false;
  }
  return true;
}

void Process::kill(int signal) {
  if (pid_ > 0 && !reap(false)) ::kill(pid_, signal);
}

std::optional<int> Process::wait(std::chrono::milliseconds deadline) {
  if (!waitFor([&] { return reap(false); }, deadline)) return std::nullopt;
  return status_;
}

bool Process::running() { return !reap(false); }

std::string Process::out() const { return readFile(outPath_); }
std::string Process::err() const { return readFile(errPath_); }

std::string Process::describe() {
  std::string text = "process";
  for (const auto& arg : argv_) text += " " + arg;
  text += "\n  pid " + std::to_string(pid_) + ", ";
  text += running() ? std::string("running")
                    : "ended with " + std::to_string(*status_) + (*status_ < 0 ? " (signal)" : "");
  auto tail = [](std::string s) {
    constexpr std::size_t kMax = 6000;
    return s.size() > kMax ? "..." + s.substr(s.size() - kMax) : s;
  };
  text += "\n  --- stdout ---\n" + tail(out()) + "\n  --- stderr ---\n" + tail(err());
  return text;
}

std::string peisCliPath() {
#ifdef PEIS_CLI_PATH
  return PEIS_CLI_PATH;
#else
#error "PEIS_CLI_PATH must name the peis binary (tests/CMakeLists.txt defines it)"
#endif
}

std::vector<std::string> cliArgs(const std::string& ecology, std::vector<std::string> args) {
  std::vector<std::string> argv{peisCliPath()};
  argv.insert(argv.end(), args.begin(), args.end());
  argv.push_back("--peis-ecology");
  argv.push_back(ecology);
  return argv;
}

std::string uniqueEcology(const std::string& tag) {
  return "it-" + tag + "-" + std::to_string(getpid());
}

}  // namespace peis::test
