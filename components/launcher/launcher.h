// Launcher: the PEIS shell of peis-init. For each component file it keeps a
// Supervisor, starts and stops the program through ChildProcesses when
// components.<name>.reqState is written, and publishes what happens as the
// tuples components.<name>.{currState,status,pid,exitCode,restarts,stdout,
// stderr} (docs/operating.md lists them; their names are in
// peis/conventions.h, where the meta-level reads them too). Everything but the constructor,
// stopAll and the destructor runs on the kernel thread.
#pragma once

#include <peis/kernel.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "launcher/component_file.h"

namespace peis::launcher {

struct LauncherSettings {
  std::string folder;                           // where the component files are
  std::vector<std::string> environment;         // NAME=value: the base environment of every run
  std::string path;                             // PATH for programs named without a '/'
  std::string logDir;                           // when not empty: DIR/<name>.log gets all output
  std::chrono::milliseconds outputPeriod{100};  // stdout/stderr tuples at most this often
};

class Launcher {
 public:
  // Publishes the tuples and applies every component's initial state (or a
  // reqState given with --peis-set-tuple). Not on the kernel thread.
  Launcher(Kernel& kernel, std::vector<ComponentFile> components, LauncherSettings settings);
  // Kills (SIGKILL) whatever still runs; call stopAll first for a clean stop.
  ~Launcher();
  Launcher(const Launcher&) = delete;
  Launcher& operator=(const Launcher&) = delete;

  // Stops every component that runs (SIGTERM, SIGKILL after its grace) and
  // waits until all have ended, at most `limit`; true if they did. Their
  // reqState tuples are left as they are. Not on the kernel thread.
  bool stopAll(std::chrono::milliseconds limit);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::launcher
