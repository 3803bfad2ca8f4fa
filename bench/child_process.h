// A child process running this benchmark program in another role, its stdout
// on a pipe: how every benchmark puts each peer in a process of its own.
// posix_spawn (a vfork: no copy of the parent's page tables) of
// /proc/self/exe; the pipes are close-on-exec, so a child inherits only its
// own stdout, not the pipes of the children started before it. The child
// arranges to die with the parent itself (PR_SET_PDEATHSIG in its role).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace peis::bench {

class Child {
 public:
  explicit Child(std::vector<std::string> args) {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
    std::vector<char*> argv;
    // The program's path as read from the link (under valgrind that is the
    // program's, not valgrind's, so `--trace-children=yes` profiles the peers).
    static std::string self = [] {
      char path[4096];
      const auto n = readlink("/proc/self/exe", path, sizeof path - 1);
      return n > 0 ? std::string(path, static_cast<std::size_t>(n)) : std::string("/proc/self/exe");
    }();
    // PEIS_BENCH_CHILD_PREFIX (words split at spaces, e.g. "valgrind
    // --tool=callgrind") runs the children under that program, the parent
    // not: to profile one side of a measurement alone.
    static std::vector<std::string> prefix = [] {
      std::vector<std::string> words;
      const char* text = std::getenv("PEIS_BENCH_CHILD_PREFIX");
      for (const char* p = text ? text : ""; *p != '\0';) {
        const char* end = std::strchr(p, ' ');
        if (end == nullptr) end = p + std::strlen(p);
        if (end > p) words.emplace_back(p, end);
        p = *end == '\0' ? end : end + 1;
      }
      return words;
    }();
    for (auto& word : prefix) argv.push_back(word.data());
    argv.push_back(self.data());
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 1);  // dup2 clears close-on-exec
    const int error =
        prefix.empty() ? posix_spawn(&pid_, self.c_str(), &actions, nullptr, argv.data(), environ)
                       : posix_spawnp(&pid_, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (error != 0) {
      close(fds[0]);
      pid_ = -1;
      throw std::runtime_error("posix_spawn failed");
    }
    out_ = fdopen(fds[0], "r");
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    if (out_) fclose(out_);
  }
  // Reads one line of the child's stdout (blocking; empty at its end).
  std::string line() {
    char buffer[4096];
    if (!fgets(buffer, sizeof buffer, out_)) return {};
    std::string text(buffer);
    if (!text.empty() && text.back() == '\n') text.pop_back();
    return text;
  }
  pid_t pid() const { return pid_; }
  void stop() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
  }

 private:
  pid_t pid_ = -1;
  FILE* out_ = nullptr;
};

}  // namespace peis::bench
