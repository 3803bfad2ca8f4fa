// Running a scenario; see runner.h. The run goes through four phases on the
// main thread — prepare (work directory, launch plan, trace, the runner's
// own PEIS), start (every process, then every PEIS joined), run (goals,
// faults, conditions, until they all held or one missed its deadline) and
// finish (the picture, stopping every process, the verdicts) — while the
// runner's kernel thread feeds the timeline, the trace and the conditions
// from the tuples it is subscribed to.
#include "runner.h"

#include <fnmatch.h>
#include <netinet/in.h>
#include <peis/kernel.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include "child_process.h"
#include "condition.h"
#include "condition_tracker.h"
#include "launch_plan.h"
#include "program_finder.h"
#include "sim_clock.h"
#include "timeline.h"
#include "trace_writer.h"
#include "tuple_watch.h"

namespace peis::scenario {
namespace {

using Steady = std::chrono::steady_clock;
using namespace std::chrono_literals;

// A base port of the simulated radio whose slots are free now (the medium
// binds a range of UDP ports; runs side by side must not share one).
int freeRadioPort() {
  std::random_device random;
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int base = 30000 + static_cast<int>(random() % 3000) * 8;
    bool free = true;
    for (int i = 0; i < 8 && free; ++i) {
      const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
      sockaddr_in address{};
      address.sin_family = AF_INET;
      address.sin_port = htons(static_cast<std::uint16_t>(base + i));
      address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      free = fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
      if (fd >= 0) ::close(fd);
    }
    if (free) return base;
  }
  return 47100;
}

bool isNumber(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// SIGINT or SIGTERM within `ms` (both blocked in every thread), or 0.
int takeSignal(int ms) {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  timespec wait{ms / 1000, (ms % 1000) * 1'000'000L};
  const int s = ::sigtimedwait(&set, nullptr, &wait);
  return s > 0 ? s : 0;
}

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", s);
  return buf;
}

class Runner {
 public:
  Runner(const Scenario& s, const RunOptions& o, const ProgramFinder& f, Timeline& t)
      : scenario_(s),
        options_(o),
        finder_(f),
        timeline_(t),
        speed_(o.speed.value_or(s.speed)),
        clock_(speed_, s.world.has_value()),
        tracker_(s.success, s.deadline) {
    faults_ = s.faults;
    faults_.insert(faults_.end(), o.injected.begin(), o.injected.end());
    std::stable_sort(faults_.begin(), faults_.end(),
                     [](const Fault& a, const Fault& b) { return a.at < b.at; });
    goalsDone_.assign(s.goals.size(), false);
    faultsDone_.assign(faults_.size(), false);
    lastNarrated_.resize(s.timeline.size());
    worldName_ = s.world ? s.world->name : "";
    for (const auto& c : s.success) {
      watched_[c.owner].insert(c.key);
      if (!c.test.nearOwner.empty()) watched_[c.test.nearOwner].insert(c.test.nearKey);
    }
    for (const auto& n : s.timeline) watched_[n.owner].insert(n.key);
    for (const auto& f : faults_) {
      if (f.kind == FaultKind::Freeze) watched_[f.peis];  // its id is needed
    }
    for (const auto& g : s.goals) watched_[g.owner];
    if (!worldName_.empty()) {
      watched_[worldName_].insert("sim.time");
      watched_[worldName_].insert("picture");
    }
  }

  int run() {
    int status = prepare();
    if (status == kSucceeded) status = start();
    if (status == kSucceeded) status = loop();
    return finish(status);
  }

 private:
  // --- prepare -------------------------------------------------------------------
  int prepare() {
    std::error_code ignored;
    if (options_.workDir.empty()) {
      std::string pattern = (std::filesystem::temp_directory_path(ignored) /
                             ("peis-scenario-" + scenario_.name + "-XXXXXX"))
                                .string();
      if (!::mkdtemp(pattern.data())) {
        std::cerr << "peis-scenario: cannot create a work directory " << pattern << "\n";
        return kBadScenario;
      }
      context_.dir = pattern;
      ownDir_ = true;
    } else {
      context_.dir = std::filesystem::absolute(options_.workDir, ignored).string();
      std::filesystem::create_directories(context_.dir, ignored);
    }
    context_.ecology = options_.ecology.empty()
                           ? "scenario-" + scenario_.name + "-" + std::to_string(::getpid())
                           : options_.ecology;
    context_.speed = speed_;
    context_.radioPort = freeRadioPort();
    plan_ = planLaunches(scenario_, context_, finder_, options_.without);
    if (!plan_.errors.empty()) {
      for (const auto& e : plan_.errors) std::cerr << e << "\n";
      return kBadScenario;
    }
    if (!options_.tracePath.empty()) {
      try {
        trace_ = std::make_unique<TraceWriter>(options_.tracePath, scenario_.trace.maxData);
      } catch (const std::exception& e) {
        std::cerr << "peis-scenario: " << e.what() << "\n";
        return kBadScenario;
      }
      trace_->info("scenario", scenario_.name);
      trace_->info("file", scenario_.path);
      trace_->info("ecology", context_.ecology);
      trace_->info("speed", seconds(speed_));
      trace_->info("started_us",
                   std::to_string(std::chrono::duration_cast<std::chrono::microseconds>(
                                      std::chrono::system_clock::now().time_since_epoch())
                                      .count()));
      timeline_.setSink(
          [this](std::optional<double> t, const std::string& peis, const std::string& words,
                 const std::string& tuple) { trace_->timeline(t, peis, words, tuple); });
    }
    Options options;
    options.ecology = context_.ecology;
    options.name = "scenario";
    options.tool = true;
    try {
      kernel_ = std::make_unique<Kernel>(options);
    } catch (const std::exception& e) {
      std::cerr << "peis-scenario: cannot start the runner's PEIS: " << e.what() << "\n";
      return kStartFailed;
    }
    say("scenario", "'" + scenario_.name + "' in ecology " + context_.ecology + ", speed " +
                        seconds(speed_) + ", work directory " + context_.dir);
    return kSucceeded;
  }

  // --- start ---------------------------------------------------------------------
  int start() {
    for (const auto& launch : plan_.launches) {
      try {
        children_.push_back(std::make_unique<ChildProcess>(
            launch.argv, launch.env, context_.dir + "/" + launch.label + ".log"));
      } catch (const std::exception& e) {
        say(launch.label, std::string("FAILED to start: ") + e.what());
        return kStartFailed;
      }
      exitReported_.push_back(false);
      std::string what = "started " + launch.program;
      if (launch.role == LaunchRole::Emulator) what += " (the node on the emulated ATmega128)";
      if (launch.role == LaunchRole::TinyHost) what += " (a tiny node on the host radio)";
      if (launch.role == LaunchRole::Gateway) what += " (the gateway of its UART)";
      say(launch.label, what + ", pid " + std::to_string(children_.back()->pid()));
    }
    const auto until =
        Steady::now() + std::chrono::milliseconds(static_cast<long>(scenario_.startTimeout * 1000));
    while (true) {
      if (const int s = takeSignal(20)) return interrupted(s);
      observe();
      for (std::size_t i = 0; i < children_.size(); ++i) {
        if (children_[i]->running()) continue;
        exitReported_[i] = true;
        const auto& l = plan_.launches[i];
        say(l.label, "FAILED to start: " + l.program + " ended with " + children_[i]->exitText() +
                         " before joining (log " + children_[i]->logPath() + ")");
        std::cerr << "---- the end of " << l.label << "'s log ----\n"
                  << children_[i]->logTail() << "\n";
        keep_ = true;
        return kStartFailed;
      }
      std::vector<std::string> missing;
      for (const auto& l : plan_.launches) {
        if (!joined(l)) missing.push_back(l.label);
      }
      if (missing.empty()) break;
      if (Steady::now() >= until) {
        std::string list;
        for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
        say("scenario", "FAILED to start: not joined within " + seconds(scenario_.startTimeout) +
                            " s: " + list + " (logs in " + context_.dir + ")");
        keep_ = true;
        return kStartFailed;
      }
    }
    // The world's clock must run before scenario time can start.
    const auto clockUntil = Steady::now() + 30s;
    while (!clock_.simulated()) {
      if (const int s = takeSignal(20)) return interrupted(s);
      observe();
      if (Steady::now() >= clockUntil) {
        say("scenario", "FAILED to start: the world publishes no sim.time");
        keep_ = true;
        return kStartFailed;
      }
    }
    clock_.start();
    say("scenario", "every PEIS joined: scenario time starts");
    if (scenario_.world && scenario_.world->daylight) {
      const std::string lux = seconds(*scenario_.world->daylight);
      write(worldName_, "physics.daylight", lux, "the weather: daylight " + lux + " lux");
    }
    std::vector<ConditionTracker::Held> held;
    {
      std::lock_guard lock(mu_);
      held = tracker_.start(0);
    }
    reportHeld(held);
    return kSucceeded;
  }

  bool joined(const Launch& l) {
    std::lock_guard lock(mu_);
    if (l.joinId) return names_.count(static_cast<PeisId>(*l.joinId)) > 0;
    for (const auto& n : l.joinNames) {
      if (!peerNames_.count(n)) return false;
    }
    return true;
  }

  // --- run -----------------------------------------------------------------------
  int loop() {
    while (true) {
      if (const int s = takeSignal(20)) return interrupted(s);
      observe();
      const double now = clock_.now().value_or(0);
      goals(now);
      faults(now);
      for (std::size_t i = 0; i < children_.size(); ++i) {
        if (exitReported_[i] || children_[i]->running()) continue;
        exitReported_[i] = true;
        say(plan_.launches[i].label, "exited: " + children_[i]->exitText());
      }
      std::vector<ConditionTracker::Held> held;
      {
        std::lock_guard lock(mu_);
        held = tracker_.advance(now);
      }
      reportHeld(held);
      std::lock_guard lock(mu_);
      if (tracker_.allHeld()) {
        sayLocked("scenario", "SUCCESS: every success condition held");
        return kSucceeded;
      }
      if (const Condition* c = tracker_.overdue(now)) {
        failed_ = c;
        return kConditionFailed;
      }
      if (options_.until && now > *options_.until) {
        for (const auto& s : tracker_.states()) {
          if (!s.held && !failed_) failed_ = s.condition;
        }
        stoppedEarly_ = true;
        return kConditionFailed;
      }
    }
  }

  void goals(double now) {
    for (std::size_t i = 0; i < scenario_.goals.size(); ++i) {
      const Goal& g = scenario_.goals[i];
      if (goalsDone_[i] || now < g.at) continue;
      const auto id = idOf(g.owner);
      if (!id) continue;  // not joined yet: written when it is
      goalsDone_[i] = true;
      const std::string value = substitute(g.value, scenario_, context_, [](const std::string&) {});
      write(g.owner, g.key, value, "goal: " + g.owner + "." + g.key + " = " + value);
    }
  }

  // Writes a tuple of another PEIS; the timeline says so, and if it is refused.
  void write(const std::string& owner, const std::string& key, const std::string& value,
             const std::string& words) {
    const auto id = idOf(owner);
    if (!id) {
      say(owner, "cannot write " + key + ": " + owner + " has not joined");
      return;
    }
    say("scenario", words);
    kernel_->setAsync(
        *id, key, value, {}, [this, owner, key](const std::optional<Error>& error, std::uint64_t) {
          if (error)
            say(owner, "refused or did not take " + owner + "." + key + ": " + error->what());
        });
  }

  std::optional<std::size_t> launchOf(const std::string& peis) const {
    for (std::size_t i = 0; i < plan_.launches.size(); ++i) {
      if (plan_.launches[i].peis == peis && plan_.launches[i].role != LaunchRole::Gateway) return i;
    }
    return std::nullopt;
  }

  // Whether the success condition of that name held (an empty name: yes).
  bool conditionHeld(const std::string& name) {
    if (name.empty()) return true;
    std::lock_guard lock(mu_);
    for (const auto& s : tracker_.states())
      if (s.condition->name == name) return s.held;
    return false;
  }

  void faults(double now) {
    for (std::size_t i = 0; i < faults_.size(); ++i) {
      const Fault& f = faults_[i];
      if (faultsDone_[i] || now < f.at || !conditionHeld(f.after)) continue;
      faultsDone_[i] = true;
      inject(f, now);
    }
    for (auto it = faultEnds_.begin(); it != faultEnds_.end();) {
      if (now < it->first) {
        ++it;
        continue;
      }
      it->second();
      it = faultEnds_.erase(it);
    }
  }

  void inject(const Fault& f, double now) {
    const auto index = launchOf(f.peis);
    if (!index) {
      say(f.peis, "fault '" + f.describe() + "' hits nothing: no such process");
      return;
    }
    ChildProcess& child = *children_[*index];
    const Launch& launch = plan_.launches[*index];
    {
      std::lock_guard lock(mu_);
      lastFault_ = f.describe();
      lastFaultAt_ = now;
    }
    const std::string pid = "pid " + std::to_string(child.pid());
    switch (f.kind) {
      case FaultKind::Kill:
        say(f.peis, "FAULT: kill -9 (" + pid + ")");
        child.signal(SIGKILL);
        break;
      case FaultKind::Stop:
        say(f.peis, "FAULT: stopped with SIGSTOP for " + seconds(*f.duration) + " s (" + pid + ")");
        child.signal(SIGSTOP);
        faultEnds_.emplace_back(now + *f.duration, [this, &child, f] {
          child.signal(SIGCONT);
          say(f.peis, "resumed with SIGCONT");
        });
        break;
      case FaultKind::Cut: {
        say(f.peis, "FAULT: radio link cut" +
                        (f.duration ? " for " + seconds(*f.duration) + " s" : std::string()));
        std::ofstream(launch.radioControl) << "cut\n";
        if (f.duration) {
          const std::string file = launch.radioControl;
          faultEnds_.emplace_back(now + *f.duration, [this, file, f] {
            std::error_code ignored;
            std::filesystem::remove(file, ignored);
            say(f.peis, "radio link restored");
          });
        }
        break;
      }
      case FaultKind::Freeze:
        write(f.peis, "fault.freeze", "on",
              "FAULT: " + f.peis + "'s sensor readings freeze" +
                  (f.duration ? " for " + seconds(*f.duration) + " s" : std::string()));
        if (f.duration) {
          faultEnds_.emplace_back(now + *f.duration, [this, f] {
            write(f.peis, "fault.freeze", "off", f.peis + "'s sensor readings move again");
          });
        }
        break;
    }
  }

  // --- watching the ecology (main thread and kernel thread) ---------------------
  std::optional<PeisId> idOf(const std::string& owner) {
    if (isNumber(owner)) return static_cast<PeisId>(std::stoll(owner));
    std::lock_guard lock(mu_);
    const auto it = ids_.find(owner);
    if (it == ids_.end()) return std::nullopt;
    return it->second;
  }

  std::string displayName(PeisId id) {
    std::lock_guard lock(mu_);
    const auto it = names_.find(id);
    return it == names_.end() ? std::to_string(id) : it->second;
  }

  // Joins, leaves, owners to resolve; on the main thread every tick.
  void observe() {
    const auto peers = kernel_->peers();
    std::set<PeisId> now;
    std::vector<PeerInfo> joined;
    {
      std::lock_guard lock(mu_);
      for (const auto& p : peers) {
        if (p.hops == 0 || p.tool) continue;
        now.insert(p.id);
        if (present_.count(p.id)) continue;
        present_.insert(p.id);
        std::string name = p.name;
        for (const auto& l : plan_.launches) {
          if (l.joinId && static_cast<PeisId>(*l.joinId) == p.id) name = l.peis;
        }
        names_[p.id] = name;
        peerNames_.insert(p.name);
        if (!ids_.count(name)) ids_[name] = p.id;
        if (!ids_.count(p.name)) ids_[p.name] = p.id;
        joined.push_back(p);
      }
    }
    for (const auto& p : joined) onJoin(p);
    std::vector<PeisId> gone;
    {
      std::lock_guard lock(mu_);
      for (auto it = present_.begin(); it != present_.end();) {
        if (now.count(*it)) {
          ++it;
          continue;
        }
        gone.push_back(*it);
        it = present_.erase(it);
      }
    }
    for (const auto id : gone) {
      if (!stopping_) say(displayName(id), "left the ecology (PEIS " + std::to_string(id) + ")");
    }
    for (auto& [owner, keys] : watched_) {
      if (resolved_.count(owner)) continue;
      const auto id = idOf(owner);
      if (!id) continue;
      resolved_.insert(owner);
      for (const auto& key : keys) watch(owner, *id, key);
    }
  }

  void onJoin(const PeerInfo& p) {
    const std::string name = displayName(p.id);
    std::string program;
    long long pid = 0;
    for (std::size_t i = 0; i < plan_.launches.size(); ++i) {
      const auto& l = plan_.launches[i];
      const bool byName =
          std::find(l.joinNames.begin(), l.joinNames.end(), p.name) != l.joinNames.end();
      const bool byId = l.joinId && static_cast<PeisId>(*l.joinId) == p.id;
      if (!byName && !byId) continue;
      program = l.program;
      if (i < children_.size()) pid = children_[i]->pid();
    }
    std::string what = "joined the ecology as PEIS " + std::to_string(p.id);
    if (name != p.name) what += " ('" + p.name + "')";
    say(name, what);
    if (trace_) trace_->peis(p.id, p.name, program, pid);
    traceOwner(p);
  }

  // The runner subscribes to every tuple of every PEIS, for the trace and
  // the configuration changes on the timeline, except keys matching a skip
  // glob (whose PEIS it then follows key by key).
  bool skipped(const std::string& owner, PeisId id, const std::string& key) const {
    for (const auto& glob : scenario_.trace.skip) {
      for (const auto& name : {owner, std::to_string(id)}) {
        if (::fnmatch(glob.c_str(), (name + "." + key).c_str(), 0) == 0) return true;
      }
    }
    return false;
  }

  void traceOwner(const PeerInfo& p) {
    bool mayHaveSkips = false;
    for (const auto& glob : scenario_.trace.skip) {
      const auto owner = glob.substr(0, glob.find('.'));
      for (const auto& name : {p.name, std::to_string(p.id)})
        mayHaveSkips |= ::fnmatch(owner.c_str(), name.c_str(), 0) == 0;
    }
    const PeisId id = p.id;
    // Callbacks first, then the subscription: a value that arrives at once
    // (before a callback registered after it) would never be an event.
    if (!mayHaveSkips) {
      kernel_->onChange(Pattern("**", id), [this](const Tuple& t) { record(t, false); });
      kernel_->onDelete(Pattern("**", id), [this](const Tuple& t) { record(t, true); });
      kernel_->subscribe(Pattern("**", id));
      return;
    }
    const std::string name = p.name;
    kernel_->onChange(Pattern::exact(id, special::kAllKeys), [this, id, name](const Tuple& t) {
      std::istringstream keys(t.data);
      for (std::string key; keys >> key;) {
        if (skipped(name, id, key)) continue;
        {
          std::lock_guard lock(mu_);
          if (!tracedKeys_.insert({id, key}).second) continue;
        }
        kernel_->onChange(Pattern::exact(id, key), [this](const Tuple& v) { record(v, false); });
        kernel_->onDelete(Pattern::exact(id, key), [this](const Tuple& v) { record(v, true); });
        kernel_->subscribe(Pattern::exact(id, key));
      }
    });
    kernel_->subscribe(Pattern::exact(id, special::kAllKeys));
  }

  // Kernel thread: one tuple change for the trace; configuration changes
  // (meta tuples) also go on the timeline.
  void record(const Tuple& t, bool deleted) {
    const auto now = clock_.now();
    if (trace_) trace_->tuple(t, deleted, now);
    if (deleted || t.mimetype != kMetaMimetype) return;
    {
      // An input declared empty at start is no configuration.
      std::lock_guard lock(mu_);
      const auto key = std::pair{t.owner, t.key};
      const auto last = lastMeta_.find(key);
      const bool known = last != lastMeta_.end();
      if ((known && last->second == t.data) || (!known && t.data.empty())) {
        lastMeta_[key] = t.data;
        return;
      }
      lastMeta_[key] = t.data;
    }
    std::string target = "nothing";
    if (!t.data.empty()) {
      target = t.data;
      const auto dot = target.find('.');
      if (dot != std::string::npos && isNumber(target.substr(0, dot)))
        target = displayName(static_cast<PeisId>(std::stoll(target.substr(0, dot)))) +
                 target.substr(dot);
    }
    std::string words = "configuration: " + t.key + " now reads " + target;
    {
      std::lock_guard lock(mu_);
      if (now && lastFaultAt_ && *now >= *lastFaultAt_)
        words += " (" + seconds(*now - *lastFaultAt_) + " s after " + lastFault_ + ")";
    }
    say(displayName(t.owner), words, displayName(t.owner) + "." + t.key + " = " + target);
  }

  // The value already cached counts too (tuple_watch.h: why).
  void watch(const std::string& owner, PeisId id, const std::string& key) {
    watches_.push_back(std::make_unique<TupleWatch>(
        *kernel_, id, key, [this, owner, key](const Tuple* t) { onValue(owner, key, t); }));
  }

  // Kernel thread: a watched tuple changed (nullptr: deleted).
  void onValue(const std::string& owner, const std::string& key, const Tuple* t) {
    if (t && owner == worldName_ && key == "sim.time") {
      try {
        clock_.worldTime(std::stod(t->data));
      } catch (const std::exception&) {
      }
    }
    const auto now = clock_.now();
    for (std::size_t i = 0; i < scenario_.timeline.size(); ++i) {
      const Narration& n = scenario_.timeline[i];
      if (!t || n.owner != owner || n.key != key) continue;
      const auto selected = selectPart(n.select, t->data);
      if (!selected) continue;
      if (n.when && !evaluate(*n.when, selected).held) continue;
      {
        std::lock_guard lock(mu_);
        if (lastNarrated_[i] == *selected) continue;
        lastNarrated_[i] = *selected;
      }
      Tuple shown = *t;
      shown.data = *selected;
      std::string words = n.say;
      for (std::size_t at; (at = words.find("{value}")) != std::string::npos;)
        words.replace(at, 7, formatValue(shown, 80));
      say(owner, words, owner + "." + key + " = " + formatValue(*t));
    }
    std::vector<ConditionTracker::Held> held;
    {
      std::lock_guard lock(mu_);
      held = tracker_.value(owner, key, t ? std::optional<std::string>(t->data) : std::nullopt,
                            now.value_or(0));
    }
    reportHeld(held);
  }

  void reportHeld(const std::vector<ConditionTracker::Held>& held) {
    for (const auto& h : held) say("scenario", "condition '" + h.name + "' holds: " + h.detail);
  }

  void say(const std::string& peis, const std::string& words, const std::string& tuple = "") {
    timeline_.say(clock_.now(), peis, words, tuple);
  }
  void sayLocked(const std::string& peis, const std::string& words) { say(peis, words); }

  int interrupted(int signal) {
    say("scenario", std::string("interrupted by ") + (signal == SIGINT ? "SIGINT" : "SIGTERM") +
                        ": stopping everything");
    keep_ = true;
    return signal == SIGINT ? kInterrupted : 143;
  }

  // --- finish ----------------------------------------------------------------------
  int finish(int status) {
    if (status == kConditionFailed && failed_) {
      std::string detail;
      {
        std::lock_guard lock(mu_);
        for (const auto& s : tracker_.states()) {
          if (s.condition == failed_) detail = s.detail;
        }
      }
      const double by = stoppedEarly_ ? *options_.until : tracker_.deadline(*failed_);
      say("scenario", "FAILED: condition '" + failed_->name + "' did not hold by " + seconds(by) +
                          " s" + (stoppedEarly_ ? " (--until)" : "") + " (last seen: " + detail +
                          ")");
    }
    if (kernel_ && status != kInterrupted && status != 143 && status != kBadScenario) picture();
    stopAll();
    if (kernel_) {
      std::lock_guard lock(mu_);
      for (const auto& s : tracker_.states()) {
        const auto& c = *s.condition;
        const std::string line =
            s.held ? "  held      " + c.name + " (at " + seconds(*s.at) + " s: " + s.detail + ")"
                   : "  NOT HELD  " + c.name + " (by " + seconds(tracker_.deadline(c)) +
                         " s; last seen: " + s.detail + ")";
        std::printf("%s\n", line.c_str());
        if (trace_) trace_->condition(c.name, s.held, s.at, s.detail);
      }
      std::fflush(stdout);
    }
    kernel_.reset();
    if (trace_) {
      const char* result = status == kSucceeded         ? "success"
                           : status == kConditionFailed ? "condition failed"
                           : status == kStartFailed     ? "start failed"
                           : status == kBadScenario     ? "bad scenario"
                                                        : "interrupted";
      trace_->info("result", result);
      if (failed_) trace_->info("failed_condition", failed_->name);
      trace_->info("ended_us",
                   std::to_string(std::chrono::duration_cast<std::chrono::microseconds>(
                                      std::chrono::system_clock::now().time_since_epoch())
                                      .count()));
      timeline_.setSink({});
      trace_->close();
      std::printf("trace: %s (%llu tuple changes)\n", options_.tracePath.c_str(),
                  static_cast<unsigned long long>(trace_->tuplesWritten()));
    }
    for (const auto& l : plan_.launches) {
      std::error_code ignored;
      if (!l.radioControl.empty()) std::filesystem::remove(l.radioControl, ignored);
    }
    if (status != kSucceeded) keep_ = true;
    if (ownDir_ && !keep_ && !options_.keepWorkDir) {
      std::error_code ignored;
      std::filesystem::remove_all(context_.dir, ignored);
    } else if (!context_.dir.empty()) {
      std::printf("logs: %s\n", context_.dir.c_str());
    }
    std::fflush(stdout);
    return status;
  }

  void picture() {
    if (options_.picturePath.empty() || worldName_.empty()) return;
    const auto world = idOf(worldName_);
    const auto index = launchOf(worldName_);
    if (!world || !index || !children_[*index]->running()) {
      say("scenario", "no picture: the world is not running");
      return;
    }
    const auto before = kernel_->get(*world, "picture");
    const std::uint64_t seqno = before ? before->seqno : 0;
    try {
      kernel_->set(*world, "picture.request", "end of the run");
    } catch (const Error& e) {
      say("scenario", std::string("no picture: ") + e.what());
      return;
    }
    const auto until = Steady::now() + 15s;
    while (Steady::now() < until) {
      const auto p = kernel_->get(*world, "picture");
      if (p && p->seqno > seqno) {
        std::ofstream out(options_.picturePath, std::ios::binary);
        out.write(p->data.data(), static_cast<std::streamsize>(p->data.size()));
        say("scenario", out ? "the world's picture of the run: " + options_.picturePath
                            : "cannot write the picture to " + options_.picturePath);
        return;
      }
      std::this_thread::sleep_for(20ms);
    }
    say("scenario", "no picture: the world did not draw one within 15 s");
  }

  // Stops every process it started, by pid: SIGCONT (a stopped one must
  // hear SIGTERM), SIGTERM, and SIGKILL after 5 s.
  void stopAll() {
    stopping_ = true;
    if (children_.empty()) return;
    for (auto it = children_.rbegin(); it != children_.rend(); ++it) {
      (*it)->signal(SIGCONT);
      (*it)->signal(SIGTERM);
    }
    const auto until = Steady::now() + 5s;
    auto anyRunning = [&] {
      return std::any_of(children_.begin(), children_.end(),
                         [](const auto& c) { return c->running(); });
    };
    while (anyRunning() && Steady::now() < until) std::this_thread::sleep_for(10ms);
    std::size_t killed = 0;
    for (auto& c : children_) {
      if (!c->running()) continue;
      c->signal(SIGKILL);
      ++killed;
    }
    while (anyRunning()) std::this_thread::sleep_for(5ms);
    std::string pids;
    for (const auto& c : children_) pids += (pids.empty() ? "" : " ") + std::to_string(c->pid());
    say("scenario", "stopped the " + std::to_string(children_.size()) +
                        " processes it started (pids " + pids + ")" +
                        (killed ? ", " + std::to_string(killed) + " of them with SIGKILL" : ""));
  }

  const Scenario& scenario_;
  const RunOptions& options_;
  const ProgramFinder& finder_;
  Timeline& timeline_;
  double speed_;
  SimClock clock_;
  RunContext context_;
  LaunchPlan plan_;
  std::vector<Fault> faults_;
  std::vector<bool> goalsDone_, faultsDone_, exitReported_;
  std::vector<std::pair<double, std::function<void()>>> faultEnds_;
  std::vector<std::unique_ptr<ChildProcess>> children_;
  std::unique_ptr<TraceWriter> trace_;
  std::unique_ptr<Kernel> kernel_;
  std::string worldName_;
  bool ownDir_ = false, keep_ = false;
  std::atomic<bool> stopping_{false};
  const Condition* failed_ = nullptr;
  bool stoppedEarly_ = false;  // --until came first
  // What a scenario owner name needs watched, and which are resolved (main thread).
  std::map<std::string, std::set<std::string>> watched_;
  std::set<std::string> resolved_;

  std::mutex mu_;  // guards what follows (kernel thread and main thread)
  ConditionTracker tracker_;
  std::map<std::string, PeisId> ids_;    // scenario or PEIS name -> id
  std::map<PeisId, std::string> names_;  // id -> the name the timeline shows
  std::set<std::string> peerNames_;      // the PEIS names seen
  std::set<PeisId> present_;
  std::set<std::pair<PeisId, std::string>> tracedKeys_;
  std::map<std::pair<PeisId, std::string>, std::string> lastMeta_;  // meta tuples seen
  std::vector<std::unique_ptr<TupleWatch>> watches_;  // the tuples conditions and narration name
  std::vector<std::string> lastNarrated_;
  std::string lastFault_;
  std::optional<double> lastFaultAt_;
};

}  // namespace

int runScenario(const Scenario& scenario, const RunOptions& options, const ProgramFinder& finder,
                Timeline& timeline) {
  Runner runner(scenario, options, finder, timeline);
  return runner.run();
}

}  // namespace peis::scenario
