// peis-init (`peis init FOLDER`): the launcher of one machine, as peisinit
// was. It reads the component files of FOLDER, runs as a PEIS, starts and
// stops each component when its components.<name>.reqState is written, and
// publishes how they do. docs/operating.md.
#include <peis/component.h>
#include <peis/descriptor.h>
#include <peis/log.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>

#include "common/command_line.h"
#include "launcher/component_file.h"
#include "launcher/launcher.h"

extern char** environ;

namespace {

const char* kUsage = R"usage(Usage: peis-init FOLDER [OPTIONS] [--peis-* flags]
       peis init FOLDER [OPTIONS]

The launcher of this machine: reads the component files (*.yaml, *.yml) of
FOLDER and runs as a PEIS that starts and stops each component when its
tuple components.<name>.reqState is set to on or off. It publishes
components.<name>.currState (off, starting, on, stopping, restarting,
failed), .status, .pid, .exitCode, .restarts and the last lines of .stdout
and .stderr. A crashed component is restarted with exponential back-off,
and marked failed after max-restarts in a row. Stopping sends SIGTERM, then
SIGKILL after the component's stop-grace (5 s unless its file says so).
When the launcher stops (SIGINT, SIGTERM, kernel.do-quit), it stops every
component first. The file format is in docs/operating.md.

Options:
  --check          read the component files, list them, and exit
                   (0: all valid; 2: the problems, as file:line: problem)
  --log-dir DIR    also append each component's output to DIR/<name>.log
  --help           this text

Example:
  peis init /etc/peis/components --peis-name launcher-kitchen
  peis set launcher-kitchen.components.tracker.reqState on
)usage";

int usageError(const std::string& why) {
  std::cerr << "peis-init: " << why << " (see --help)\n";
  return 2;
}

void list(const std::vector<peis::launcher::ComponentFile>& components) {
  for (const auto& c : components) {
    std::cout << c.name << ": " << c.executable << " (" << c.file << "), start "
              << (c.startOn ? "on" : "off") << ", restart " << toString(c.restart.policy)
              << (c.peisName.empty() ? "" : ", PEIS '" + c.peisName + "'") << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  peis::Options options;
  if (const auto code =
          peis::components::parsePeisOptions(argc, argv, "peis-init", kUsage, "launcher", options))
    return *code;
  std::string folder, logDir;
  bool check = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--check") {
      check = true;
    } else if (arg == "--log-dir") {
      if (i + 1 >= argc) return usageError("--log-dir needs a folder");
      logDir = argv[++i];
    } else if (arg.rfind("--log-dir=", 0) == 0) {
      logDir = arg.substr(10);
    } else if (arg.rfind("-", 0) == 0 && arg != "-") {
      return usageError("unknown option " + arg);
    } else if (folder.empty()) {
      folder = arg;
    } else {
      return usageError("one FOLDER only, not also '" + arg + "'");
    }
  }
  if (folder.empty()) return usageError("FOLDER is missing");

  std::vector<peis::launcher::ComponentFile> components;
  try {
    components = peis::launcher::loadComponentFolder(folder);
    for (const auto& c : components) {
      if (!c.descriptor.empty()) peis::Descriptor::fromFile(c.descriptor);
    }
  } catch (const peis::Error& e) {
    std::cerr << e.what() << "\n";
    return 2;
  }
  if (check) {
    list(components);
    return 0;
  }
  if (components.empty()) std::cerr << "peis-init: " << folder << " has no component files\n";
  if (!logDir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(logDir, ec);
    if (!std::filesystem::is_directory(logDir)) return usageError("cannot use --log-dir " + logDir);
    logDir = std::filesystem::absolute(logDir).string();
  }

  std::unique_ptr<peis::Kernel> started;
  try {
    started = std::make_unique<peis::Kernel>(options);
  } catch (const peis::Error& e) {  // a TCP port taken, a bad PEIS_DISCOVERY_SCOPE
    return usageError(e.what());
  }
  peis::Kernel& kernel = *started;
  peis::Component self(kernel, "launcher");
  peis::launcher::LauncherSettings settings;
  settings.folder = std::filesystem::absolute(folder).lexically_normal().string();
  settings.logDir = logDir;
  for (char** e = environ; *e != nullptr; ++e) settings.environment.emplace_back(*e);
  // The components join the launcher's ecology unless their files say otherwise.
  settings.environment.push_back("PEIS_ECOLOGY=" + kernel.options().ecology);
  settings.environment.push_back("PEIS_DISCOVERY_PORT=" +
                                 std::to_string(kernel.options().discoveryPort));
  const char* path = std::getenv("PATH");
  settings.path = path ? path : "/usr/local/bin:/usr/bin:/bin";
  std::chrono::milliseconds longestGrace{0};
  for (const auto& c : components) longestGrace = std::max(longestGrace, c.restart.stopGrace);

  peis::launcher::Launcher launcher(kernel, std::move(components), settings);
  self.start();
  std::cerr << "peis-init: PEIS " << kernel.id() << " '" << kernel.name() << "' on port "
            << kernel.port() << ", " << settings.folder << std::endl;
  const std::string reason = kernel.run();
  std::cerr << "peis-init: " << reason << "; stopping the components" << std::endl;
  const bool stopped = launcher.stopAll(longestGrace + std::chrono::seconds(5));
  if (!stopped) std::cerr << "peis-init: some components did not end; killing them" << std::endl;
  return 0;
}
