// The PEIS shell of peis-init (see launcher.h).
#include "launcher/launcher.h"

#include <peis/log.h>

#include <condition_variable>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <sstream>

#include "launcher/child_processes.h"
#include "launcher/output_tail.h"
#include "launcher/supervisor.h"
#include "peis/conventions.h"

namespace peis::launcher {

namespace {

namespace cv = conventions;

using Clock = std::chrono::steady_clock;

struct Entry {
  explicit Entry(ComponentFile f)
      : file(std::move(f)),
        supervisor(file.restart),
        out(static_cast<std::size_t>(file.outputLines)),
        err(static_cast<std::size_t>(file.outputLines)) {}
  ComponentFile file;
  Supervisor supervisor;
  OutputTail out, err;
  RunId run = 0;  // the current run, 0 before the first
  TimerHandle timer = 0;
  std::optional<TimePoint> armedFor;
  std::optional<Published> published;
};

std::string optionalText(const std::optional<int>& value) {
  return value ? std::to_string(*value) : std::string();
}

// The environment of a run: the base, then the file's entries (which win).
std::vector<std::string> environmentOf(const std::vector<std::string>& base,
                                       const ComponentFile& file) {
  std::map<std::string, std::string> byName;
  std::vector<std::string> order;
  const auto put = [&](const std::string& name, const std::string& value) {
    if (byName.find(name) == byName.end()) order.push_back(name);
    byName[name] = value;
  };
  for (const auto& entry : base) {
    const auto eq = entry.find('=');
    if (eq != std::string::npos) put(entry.substr(0, eq), entry.substr(eq + 1));
  }
  for (const auto& [name, value] : file.environment) put(name, value);
  std::vector<std::string> result;
  for (const auto& name : order) result.push_back(name + "=" + byName[name]);
  return result;
}

}  // namespace

struct Launcher::Impl {
  Kernel& kernel;
  LauncherSettings settings;
  std::map<std::string, Entry> entries;
  std::map<RunId, std::string> runOwner;  // run -> component name
  RunId nextRun = 0;
  CallbackHandle requestCallback = 0;
  TimerHandle outputTimer = 0;
  std::unique_ptr<ChildProcesses> children;
  bool closing = false;  // set on the kernel thread when the Launcher goes away

  // How many components may have a process alive; for stopAll.
  std::mutex aliveMu;
  std::condition_variable aliveChanged;
  int alive = 0;

  Impl(Kernel& k, LauncherSettings s) : kernel(k), settings(std::move(s)) {}

  void apply(Entry& e, const Actions& actions);
  void sync(Entry& e);
  void countAlive();
  void onRequest(const Tuple& t);
  void onStarted(RunId run, pid_t pid);
  void onFailed(RunId run, const std::string& why);
  void onOutput(RunId run, Stream stream, const std::string& bytes);
  void onExited(RunId run, int code);
  void flushOutput();
  Entry* entryOfRun(RunId run) {
    const auto it = runOwner.find(run);
    if (it == runOwner.end()) return nullptr;
    const auto e = entries.find(it->second);
    return e == entries.end() ? nullptr : &e->second;
  }
};

void Launcher::Impl::apply(Entry& e, const Actions& actions) {
  if (actions.start) {
    const std::string program = resolveExecutable(e.file.executable, settings.path);
    if (program.empty()) {
      apply(e, e.supervisor.startFailed("executable '" + e.file.executable + "' not found (" +
                                            e.file.file + ":" +
                                            std::to_string(e.file.executableLine) + ")",
                                        Clock::now()));
      return;
    }
    e.run = ++nextRun;
    runOwner[e.run] = e.file.name;
    RunRequest request;
    request.run = e.run;
    request.program = program;
    request.argv = commandLine(e.file, program);
    request.environment = environmentOf(settings.environment, e.file);
    request.workingDirectory = e.file.workingDirectory;
    if (!settings.logDir.empty()) request.logFile = settings.logDir + "/" + e.file.name + ".log";
    children->start(std::move(request));
  }
  if (actions.signal) children->signal(e.run, *actions.signal);
  sync(e);
}

void Launcher::Impl::sync(Entry& e) {
  const Published& now = e.supervisor.published();
  const Published before = e.published.value_or(Published{"", "", {}, {}, -1});
  const std::string& name = e.file.name;
  if (!e.published || now.pid != before.pid)
    kernel.set(cv::launchKey(name, cv::kLaunchPid), optionalText(now.pid));
  if (!e.published || now.exitCode != before.exitCode)
    kernel.set(cv::launchKey(name, cv::kLaunchExitCode), optionalText(now.exitCode));
  if (!e.published || now.restarts != before.restarts)
    kernel.set(cv::launchKey(name, cv::kLaunchRestarts), std::to_string(now.restarts));
  // currState last: a watcher of it finds the others matching.
  if (!e.published || now.status != before.status || now.currState != before.currState)
    kernel.set(cv::launchKey(name, cv::kLaunchStatus), now.status);
  if (!e.published || now.currState != before.currState)
    kernel.set(cv::launchKey(name, cv::kLaunchCurrState), now.currState);
  if (e.published && now.currState != before.currState) {
    log::info(kernel.id(), "launcher: " + name + " " + before.currState + " -> " + now.currState +
                               (now.status != "ok" ? " (" + now.status + ")" : ""));
  }
  e.published = now;
  // The one timer of the component follows the supervisor's deadline.
  const auto deadline = e.supervisor.deadline();
  if (deadline != e.armedFor) {
    if (e.timer != 0) kernel.cancelTimer(e.timer);
    e.timer = 0;
    e.armedFor = deadline;
    if (deadline) {
      const auto wait = std::chrono::ceil<std::chrono::milliseconds>(*deadline - Clock::now());
      e.timer = kernel.after(std::max(wait, std::chrono::milliseconds(0)), [this, name] {
        auto it = entries.find(name);
        if (it == entries.end()) return;
        it->second.timer = 0;
        it->second.armedFor.reset();
        apply(it->second, it->second.supervisor.timerFired(Clock::now()));
      });
    }
  }
  countAlive();
}

void Launcher::Impl::countAlive() {
  int count = 0;
  for (const auto& [name, e] : entries) count += e.supervisor.processAlive() ? 1 : 0;
  std::lock_guard lock(aliveMu);
  alive = count;
  aliveChanged.notify_all();
}

void Launcher::Impl::onRequest(const Tuple& t) {
  if (closing) return;
  // components.<name>.reqState
  const auto parsed = cv::parseLaunchKey(t.key);
  if (!parsed || parsed->second != cv::kLaunchReqState) return;
  const std::string& name = parsed->first;
  const auto it = entries.find(name);
  if (it == entries.end()) {
    log::warn(kernel.id(), "launcher: " + t.key + " written, but there is no component '" + name +
                               "' (see launcher.components)");
    return;
  }
  apply(it->second, it->second.supervisor.request(t.data, Clock::now()));
}

void Launcher::Impl::onStarted(RunId run, pid_t pid) {
  if (closing) return;
  if (Entry* e = entryOfRun(run); e && e->run == run)
    apply(*e, e->supervisor.started(static_cast<int>(pid), Clock::now()));
}

void Launcher::Impl::onFailed(RunId run, const std::string& why) {
  if (closing) return;
  Entry* e = entryOfRun(run);
  runOwner.erase(run);
  if (e && e->run == run) apply(*e, e->supervisor.startFailed(why, Clock::now()));
}

void Launcher::Impl::onOutput(RunId run, Stream stream, const std::string& bytes) {
  if (closing) return;
  Entry* e = entryOfRun(run);
  if (!e) return;
  (stream == Stream::Stdout ? e->out : e->err).append(bytes);
  if (outputTimer == 0)
    outputTimer = kernel.after(settings.outputPeriod, [this] {
      outputTimer = 0;
      flushOutput();
    });
}

void Launcher::Impl::onExited(RunId run, int code) {
  if (closing) return;
  Entry* e = entryOfRun(run);
  runOwner.erase(run);
  if (!e || e->run != run) return;
  flushOutput();  // the last words come before the state that says it ended
  apply(*e, e->supervisor.exited(code, Clock::now()));
}

void Launcher::Impl::flushOutput() {
  for (auto& [name, e] : entries) {
    if (e.out.takeChanged()) kernel.set(cv::launchKey(name, cv::kLaunchStdout), e.out.text());
    if (e.err.takeChanged()) kernel.set(cv::launchKey(name, cv::kLaunchStderr), e.err.text());
  }
}

Launcher::Launcher(Kernel& kernel, std::vector<ComponentFile> components, LauncherSettings settings)
    : impl_(std::make_unique<Impl>(kernel, std::move(settings))) {
  Impl* impl = impl_.get();
  // Events of the watcher thread are handled on the kernel thread.
  ChildEvents events;
  events.started = [impl](RunId run, pid_t pid) {
    impl->kernel.post([impl, run, pid] { impl->onStarted(run, pid); });
  };
  events.failed = [impl](RunId run, const std::string& why) {
    impl->kernel.post([impl, run, why] { impl->onFailed(run, why); });
  };
  events.output = [impl](RunId run, Stream stream, std::string_view bytes) {
    impl->kernel.post(
        [impl, run, stream, text = std::string(bytes)] { impl->onOutput(run, stream, text); });
  };
  events.exited = [impl](RunId run, int code) {
    impl->kernel.post([impl, run, code] { impl->onExited(run, code); });
  };
  impl->children = std::make_unique<ChildProcesses>(std::move(events));

  std::string names;
  for (auto& file : components) {
    const std::string name = file.name;
    names += (names.empty() ? "" : " ") + name;
    impl->entries.emplace(name, Entry(std::move(file)));
  }
  std::promise<void> ready;
  // Set up on the kernel thread, where every later step runs too.
  kernel.post([impl, names, &ready] {
    Kernel& k = impl->kernel;
    k.set(std::string(cv::kLauncherComponents), names);
    k.set(std::string(cv::kLauncherFolder), impl->settings.folder);
    for (auto& [name, e] : impl->entries) {
      k.set(cv::launchKey(name, cv::kLaunchExecutable), e.file.executable);
      k.set(cv::launchKey(name, cv::kLaunchFile), e.file.file);
      k.set(cv::launchKey(name, cv::kLaunchPeisName), e.file.peisName);
      if (!e.file.descriptor.empty()) {
        std::ifstream in(e.file.descriptor, std::ios::binary);
        std::stringstream text;
        text << in.rdbuf();
        WriteOptions yaml;
        yaml.mimetype = "application/yaml";
        k.set(cv::launchKey(name, cv::kLaunchDescriptor), text.str(), yaml);
      }
      k.set(cv::launchKey(name, cv::kLaunchStdout), "");
      k.set(cv::launchKey(name, cv::kLaunchStderr), "");
      impl->sync(e);
    }
    // Not bound to the id: after an id re-pick the own tuples move, and
    // requests must still reach the launcher.
    impl->requestCallback =
        k.onChange(Pattern(cv::launchKey("*", cv::kLaunchReqState)), [impl](const Tuple& t) {
          if (t.owner == impl->kernel.id()) impl->onRequest(t);
        });
    // Every reqState is written (again) now, so the callback applies it: the
    // file's initial state, or a value set before (--peis-set-tuple).
    for (auto& [name, e] : impl->entries) {
      const std::string key = cv::launchKey(name, cv::kLaunchReqState);
      const auto given = k.get(key);
      k.set(key, given ? given->data : (e.file.startOn ? "on" : "off"));
    }
    ready.set_value();
  });
  ready.get_future().wait();
}

bool Launcher::stopAll(std::chrono::milliseconds limit) {
  Impl* impl = impl_.get();
  impl->kernel.post([impl] {
    for (auto& [name, e] : impl->entries) {
      if (e.supervisor.processAlive() || e.supervisor.phase() == Phase::Restarting)
        impl->apply(e, e.supervisor.request("off", Clock::now()));
    }
  });
  // The posted step above runs before the count can be trusted: wait for it.
  std::promise<void> posted;
  impl->kernel.post([&posted] { posted.set_value(); });
  posted.get_future().wait();
  std::unique_lock lock(impl->aliveMu);
  return impl->aliveChanged.wait_for(lock, limit, [impl] { return impl->alive == 0; });
}

Launcher::~Launcher() {
  Impl* impl = impl_.get();
  const auto onKernelThread = [impl](std::function<void()> fn) {
    std::promise<void> done;
    impl->kernel.post([&] {
      fn();
      done.set_value();
    });
    done.get_future().wait();
  };
  // From here on nothing of ours acts on the kernel thread.
  onKernelThread([impl] {
    impl->closing = true;
    impl->kernel.removeCallback(impl->requestCallback);
    if (impl->outputTimer != 0) impl->kernel.cancelTimer(impl->outputTimer);
    for (auto& [name, e] : impl->entries) {
      if (e.timer != 0) impl->kernel.cancelTimer(e.timer);
    }
  });
  // The watcher kills and reaps what still runs; then the events it posted
  // before it stopped have run (and done nothing) before impl_ goes.
  impl->children.reset();
  onKernelThread([] {});
}

}  // namespace peis::launcher
