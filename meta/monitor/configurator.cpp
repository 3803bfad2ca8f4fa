// The configurator's control loop (see configurator.h).
#include "monitor/configurator.h"

#include <algorithm>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "deploy/deployer.h"
#include "introspect/introspector.h"
#include "monitor/event_log.h"
#include "monitor/goal_tuples.h"
#include "monitor/health.h"
#include "peis/conventions.h"
#include "peis/error.h"
#include "peis/meta/planner.h"

namespace peis::meta {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr milliseconds kPublishEvery{100};
constexpr milliseconds kLookAgainAtLeast{500};

std::string fixed(double value, int decimals = 3) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
  return buf;
}

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct GoalSource {
  int owner = 0;
  std::string ownerName;
  std::string key;
  std::uint64_t seqno = 0;
  std::string text;
  std::string origin() const { return ownerName + "." + key; }
};

// What planning for the goal tuples gave.
struct Planned {
  bool ok = false;
  PlanResult result;
  std::string failure;  // why there is no configuration
  std::vector<GoalStatusLine> status;
  std::size_t goals = 0;
};

// The goal tuples (owner, key) that a plan's answers say are met.
std::set<std::pair<int, std::string>> meets(const std::vector<GoalStatusLine>& status) {
  std::set<std::pair<int, std::string>> met;
  for (const auto& line : status)
    if (line.state == GoalState::Deployed) met.emplace(line.owner, line.key);
  return met;
}

Model withEveryPeisAlive(Model model) {
  for (auto& p : model.peis) p.alive = true;
  model.failed.clear();
  return model;
}

std::string joined(const std::vector<std::string>& lines, const std::string& separator) {
  std::string text;
  for (const auto& l : lines) text += (text.empty() ? "" : separator) + l;
  return text;
}

}  // namespace

struct Configurator::Impl {
  Kernel& kernel;
  ConfiguratorOptions options;
  Introspector introspector;
  Deployer deployer;
  EventLog events;
  HealthMonitor monitor;
  FailedParts failed;

  // The planner and what it indexes (alive flags and failures applied on top).
  std::optional<ConfigurationPlanner> planner;
  Model plannerShape;
  std::set<std::string> appliedFailed;
  Model lastModel;
  bool haveModel = false;

  // What is deployed.
  std::optional<PlanResult> deployed;
  std::string deployedSources;  // the goal tuples it serves
  // Of those, the ones it meets (left out: pending, infeasible, refused).
  std::set<std::pair<int, std::string>> deployedMeets;
  bool hadGoals = false;
  std::optional<Clock::time_point> driftSince;
  Clock::time_point driftQuietUntil{};  // after a drift deployment that changed nothing
  // A repair that could not be deployed (no configuration, a deployment
  // that failed): tried again when the ecology changes, or after the grace period.
  bool repairPending = false;
  Clock::time_point repairRetryAt{};
  std::string publishedStatus;
  std::vector<GoalStatusLine> statusLines;  // the answers published last

  // Components this configurator asked a launcher to start, by PEIS name.
  struct Launched {
    int launcher = 0;
    std::string launcherName;
    std::string component;
  };
  std::map<std::string, Launched> launched;

  bool active = false;
  std::string role;
  std::uint64_t publishedVersion = ~0ull;
  Clock::time_point lastPublish{};

  std::mutex mu;
  std::condition_variable wake;
  bool woken = false;
  bool stopping = false;
  std::thread thread;

  Impl(Kernel& k, ConfiguratorOptions o)
      : kernel(k),
        options(resolved(k, o)),
        introspector(k),
        deployer(k, options.deploy),
        events(k, options.eventsKept),
        monitor(MonitorPolicy{options.grace, options.settle}),
        failed(options.recoverHold, options.retryAfter) {}

  static ConfiguratorOptions resolved(Kernel& k, ConfiguratorOptions o) {
    const auto liveness = k.options().liveness;
    if (o.grace.count() == 0) o.grace = liveness;
    if (o.settle.count() == 0) o.settle = o.grace;
    if (o.recoverHold.count() == 0) o.recoverHold = 2 * o.grace;
    if (o.startupWait.count() == 0) o.startupWait = 2 * liveness;
    return o;
  }

  void start() {
    introspector.setListener([this] {
      std::lock_guard lock(mu);
      woken = true;
      wake.notify_one();
    });
    setRole("standby");
    thread = std::thread([this] { run(); });
  }

  void stop() {
    {
      std::lock_guard lock(mu);
      stopping = true;
      wake.notify_one();
    }
    if (thread.joinable()) thread.join();
    introspector.setListener(nullptr);
  }

  bool stopRequested() {
    std::lock_guard lock(mu);
    return stopping;
  }

  void setRole(const std::string& newRole) {
    if (role == newRole) return;
    role = newRole;
    kernel.set("config.configurator", role);
  }

  void run() {
    events.record("started", "configurator on PEIS " + std::to_string(kernel.id()) + " '" +
                                 kernel.name() + "', grace " +
                                 std::to_string(options.grace.count()) + " ms, margin " +
                                 fixed(100 * options.switchMargin, 0) + " %");
    // Let the ecology's tuples arrive before the first plan.
    const auto until = Clock::now() + options.startupWait;
    while (!stopRequested() && Clock::now() < until) {
      if (introspector.waitSettled(milliseconds(100))) break;
    }
    while (!stopRequested()) {
      try {
        step();
      } catch (const std::exception& e) {
        events.record("error", std::string("the configurator's step failed: ") + e.what());
      }
      std::unique_lock lock(mu);
      const auto next = std::min(nextCheck(), Clock::now() + kLookAgainAtLeast);
      wake.wait_until(lock, next, [this] { return woken || stopping; });
      woken = false;
    }
  }

  Clock::time_point nextCheck() const {
    auto next = Clock::now() + kLookAgainAtLeast;
    auto consider = [&](std::optional<Clock::time_point> at) {
      if (at && *at < next) next = *at;
    };
    consider(monitor.nextCheck());
    consider(failed.nextCheck());
    if (repairPending) consider(repairRetryAt);
    if (driftSince) consider(std::max(*driftSince + options.driftHold, driftQuietUntil));
    if (publishedVersion != introspector.version()) consider(lastPublish + kPublishEvery);
    return next;
  }

  // --- one look at the ecology ---------------------------------------------------
  void step() {
    const auto version = introspector.version();
    const LiveModel live = introspector.snapshot();
    const auto now = Clock::now();
    publishModel(live, version, now);
    if (!electActive(live)) return;

    const auto sources = goalSources(live);
    const auto sourcesText = describeSources(sources);
    const Model model = live.toModel(options.costs, options.overrides);
    const bool modelChanged = !haveModel || !(model == lastModel);
    updatePlanner(model);

    std::string reason;
    bool mustSwitch = false;
    if (sourcesText != deployedSources) {
      reason = "goals";
      mustSwitch = true;
    }
    // Failures of what is deployed.
    std::vector<Failure> seen = monitor.observe(live, now);
    for (const auto& f : seen) {
      events.record("failure", f.instance.toString() + ": " + f.cause);
      failed.add(f, now);
      if (reason.empty()) reason = "repair";
      mustSwitch = true;
    }
    for (const auto& f : failed.recovered(live, now)) {
      events.record("recovered", f.instance.toString() + " can be used again (" + toString(f.kind) +
                                     " cleared)");
      if (reason.empty()) reason = "recovered";
    }
    applyFailures();
    // A pending repair means what is deployed is broken: a part back from
    // failure may mend it at once (the margin below is for working ones).
    if (repairPending && (modelChanged || now >= repairRetryAt || reason == "recovered")) {
      if (reason.empty()) reason = "repair";
      mustSwitch = true;
    }
    if (reason.empty() && modelChanged && (deployed || !sources.empty()))
      reason = "ecology changed";
    if (!reason.empty()) {
      planAndDeploy(sources, sourcesText, model, live, reason, mustSwitch);
    } else {
      refreshStatusSeqnos(sources);
      correctDrift(live, now);
    }
  }

  bool electActive(const LiveModel& live) {
    const auto* me = live.find(kernel.id());
    bool older = false;  // is another alive configurator older than this one?
    for (const auto& p : live.peis) {
      if (!p.alive || !p.configurator || p.id == kernel.id()) continue;
      if (!me || std::tie(p.incarnation, p.id) < std::tie(me->incarnation, me->id)) older = true;
    }
    const bool nowActive = me && !older;
    if (nowActive != active) {
      active = nowActive;
      setRole(active ? "active" : "standby");
      events.record(active ? "active" : "standby",
                    active ? "this configurator deploys (no older one is alive)"
                           : "an older configurator is alive: standing by");
      if (!active) {
        // The active one answers goal tuples now: no stale answers from here.
        monitor.clear();
        deployed.reset();
        deployedSources.clear();
        deployedMeets.clear();
        publishStatus({});
      }
    }
    return active;
  }

  std::vector<GoalSource> goalSources(const LiveModel& live) const {
    std::vector<GoalSource> sources;
    for (const auto& p : live.peis) {
      if (!p.alive) continue;  // a poster that is gone has withdrawn its goals
      for (const auto& [key, text] : p.goals) {
        if (text.find_first_not_of(" \t\r\n") == std::string::npos) continue;
        GoalSource s{p.id, p.name, key, 0, text};
        if (const auto t = kernel.get(p.id, key)) s.seqno = t->seqno;
        sources.push_back(std::move(s));
      }
    }
    return sources;
  }

  static std::string describeSources(const std::vector<GoalSource>& sources) {
    std::string text;
    for (const auto& s : sources)
      text += std::to_string(s.owner) + "." + s.key + "=" + s.text + "\n";
    return text;
  }

  void updatePlanner(const Model& model) {
    auto shape = withEveryPeisAlive(model);
    if (!planner || !(shape == plannerShape)) {
      planner.emplace(shape);
      plannerShape = std::move(shape);
      appliedFailed.clear();
    }
    for (const auto& p : model.peis) planner->setAlive(p.name, p.alive);
    lastModel = model;
    haveModel = true;
  }

  void applyFailures() {
    std::set<std::string> now;
    for (const auto& s : failed.selectors()) {
      now.insert(s.toString());
      if (!appliedFailed.count(s.toString())) planner->setFailed(s, true);
    }
    for (const auto& text : appliedFailed) {
      if (now.count(text)) continue;
      if (auto s = InstanceSelector::parse(text, nullptr)) planner->setFailed(*s, false);
    }
    appliedFailed = std::move(now);
  }

  // --- planning ---------------------------------------------------------------------
  PlanResult planGoals(const Goals& goals, bool quick) const {
    PlanOptions po;
    po.timeLimit = options.planTimeLimit;
    po.firstSolutionOnly = quick;
    if (deployed && deployed->ok()) po.warmStart = &deployed->configuration;
    return planner->plan(goals, po);
  }

  Planned plan(const std::vector<GoalSource>& sources) {
    Planned planned;
    std::vector<std::pair<const GoalSource*, Goals>> usable;
    for (const auto& s : sources) {
      auto parsed = parseGoalTuple(s.text, s.origin());
      if (!parsed.problems.empty()) {
        planned.status.push_back(
            {s.owner, s.key, s.seqno, GoalState::Refused, parsed.problems.front()});
        events.record("pending", s.origin() + " refused: " + parsed.problems.front());
        continue;
      }
      if (!parsed.goals.empty() || !parsed.goals.constraints.avoidPeis.empty())
        usable.emplace_back(&s, std::move(parsed.goals));
    }
    auto drop = [&](std::size_t i, GoalState state, const std::string& why) {
      planned.status.push_back(
          {usable[i].first->owner, usable[i].first->key, usable[i].first->seqno, state, why});
      events.record("pending", usable[i].first->origin() + " " + toString(state) + ": " + why);
      usable.erase(usable.begin() + static_cast<long>(i));
    };
    while (true) {
      Goals all;
      for (const auto& [s, g] : usable) mergeGoals(all, g);
      planned.goals = all.information.size() + all.run.size();
      if (all.empty()) {
        planned.ok = true;
        planned.result.status = PlanStatus::Optimal;
        return planned;
      }
      try {
        planned.result = planGoals(all, false);
      } catch (const Error& e) {
        // A goal that names what the model does not have (yet): which tuple?
        bool dropped = false;
        for (std::size_t i = usable.size(); i-- > 0;) {
          try {
            planGoals(usable[i].second, true);
          } catch (const Error& alone) {
            drop(i, GoalState::Pending, alone.what());
            dropped = true;
          }
        }
        if (!dropped) {
          planned.failure = e.what();
          for (std::size_t i = usable.size(); i-- > 0;) drop(i, GoalState::Pending, e.what());
        }
        continue;
      }
      if (planned.result.ok()) break;
      const auto why = planned.result.explanation.empty()
                           ? std::string("no configuration found in time")
                           : planned.result.explanation.front();
      // Which goal tuples cannot be met on their own?
      bool dropped = false;
      for (std::size_t i = usable.size(); i-- > 0 && usable.size() > 1;) {
        const auto alone = planGoals(usable[i].second, false);
        if (alone.status == PlanStatus::Infeasible) {
          drop(i, GoalState::Infeasible,
               alone.explanation.empty() ? why : alone.explanation.front());
          dropped = true;
        }
      }
      if (!dropped) {
        planned.failure = "no configuration: " + joined(planned.result.explanation, "; ");
        for (std::size_t i = usable.size(); i-- > 0;) drop(i, GoalState::Infeasible, why);
        return planned;
      }
    }
    planned.ok = true;
    for (const auto& [s, g] : usable)
      planned.status.push_back({s->owner, s->key, s->seqno, GoalState::Deployed, ""});
    return planned;
  }

  void planAndDeploy(const std::vector<GoalSource>& sources, const std::string& sourcesText,
                     Model model, const LiveModel& live, const std::string& reason,
                     bool mustSwitch) {
    if (reason == "goals") {
      events.record("goals", std::to_string(sources.size()) + " goal tuple(s)" +
                                 (sources.empty() ? std::string() : ": " + sourceList(sources)));
    }
    if (sources.empty() && !hadGoals) {
      // Nothing asked for yet: leave the ecology as it is.
      deployedSources = sourcesText;
      publishStatus({});
      return;
    }
    // Until a deployment succeeds, a repair stays pending.
    if (mustSwitch && reason != "goals") repairPending = true;
    repairRetryAt = Clock::now() + options.grace;
    LiveModel current = live;
    std::string lastError;
    int launchRounds = 0;
    for (int attempt = 0; attempt < 3; ++attempt) {
      const auto started = Clock::now();
      Planned planned = plan(sources);
      const double planMs = msSince(started);
      if (!planned.ok) {
        events.record("gave-up", planned.failure + " (" + reason + ")");
        publishStatus(planned.status);
        deployedSources = sourcesText;
        return;
      }
      const auto& config = planned.result.configuration;
      events.record("replanned", reason + ": cost " + fixed(config.cost) + " (" +
                                     toString(planned.result.status) + "), " +
                                     std::to_string(config.instances.size()) +
                                     " functionalities, " + std::to_string(config.links.size()) +
                                     " links, in " + fixed(planMs) + " ms" + avoiding());
      // The margin compares configurations that meet the same goal tuples:
      // one that meets a goal left out before (pending until its producer
      // appeared) is deployed whatever it costs.
      const bool meetsOthers = meets(planned.status) != deployedMeets;
      if (!mustSwitch && !meetsOthers && deployed && deployed->ok() &&
          !worthSwitching(deployed->configuration.cost, config.cost, options.switchMargin)) {
        if (!(config == deployed->configuration))
          events.record("kept", "cost " + fixed(config.cost) + " is not " +
                                    fixed(100 * options.switchMargin, 0) +
                                    " % below the deployed " + fixed(deployed->configuration.cost) +
                                    ": no switch");
        deployedSources = sourcesText;
        return;
      }
      // Components that do not run yet: their launchers start them, and the
      // configuration is planned again with their PEIS (their ids, their state).
      if (launchRounds < 2 && launchFor(config, current)) {
        ++launchRounds;
        --attempt;
        current = introspector.snapshot();
        model = current.toModel(options.costs, options.overrides);
        updatePlanner(model);
        applyFailures();
        mustSwitch = true;
        continue;
      }
      const auto result = deploy(config, current);
      if (result.ok) {
        repairPending = false;
        deployed = planned.result;
        deployedSources = sourcesText;
        deployedMeets = meets(planned.status);
        hadGoals = !sources.empty();
        monitor.deployed(config, model, Clock::now());
        driftSince.reset();
        publishStatus(planned.status);
        publishDeployed(result.generation, sources);
        stopUnused(config);
        return;
      }
      lastError = result.error;
      if (result.failedPeis == 0) break;
      // Ask again without the PEIS that did not take the writes: one that
      // went away is used again when it is back (after the hold), one that
      // refused only after the retry period.
      const bool gone = !reachable(result.failedPeis);
      Failure refused{gone ? FailureKind::PeisGone : FailureKind::StaleInput,
                      {},
                      result.failedPeis,
                      0,
                      "did not accept the deployment: " + result.error};
      refused.instance.peis =
          result.failedPeisName.empty() ? std::to_string(result.failedPeis) : result.failedPeisName;
      if (const auto* p = live.find(result.failedPeis)) refused.incarnation = p->incarnation;
      failed.add(refused, Clock::now());
      applyFailures();
      current = introspector.snapshot();
      mustSwitch = true;
    }
    // Not deployed: the goal tuples wait, and the configurator tries again when
    // the ecology changes, or after the grace period.
    std::vector<GoalStatusLine> waiting;
    for (const auto& src : sources)
      waiting.push_back(
          {src.owner, src.key, src.seqno, GoalState::Pending, "not deployed: " + lastError});
    publishStatus(waiting);
    deployedSources = sourcesText;
    repairPending = true;
    repairRetryAt = Clock::now() + options.grace;
  }

  // Deploys and records the outcome as events (deployed, deploy-failed, warnings).
  // The PEIS of failed parts: not waited on to switch anything off.
  std::set<int> failedPeisIds(const LiveModel& live) const {
    std::set<int> ids;
    for (const auto& s : failed.selectors()) {
      if (const auto* p = live.findByName(s.peis)) ids.insert(p->id);
    }
    return ids;
  }

  DeployResult deploy(const Configuration& config, const LiveModel& live) {
    const auto result = deployer.deploy(config, live, failedPeisIds(live));
    for (const auto& w : result.warnings) events.record("warning", w);
    if (!result.ok) {
      events.record("deploy-failed", result.error);
    } else if (!result.unchanged) {
      events.record("deployed", "generation " + std::to_string(result.generation) + ": " +
                                    std::to_string(result.writes) + " writes on " +
                                    std::to_string(result.peisTouched) + " PEIS in " +
                                    fixed(result.milliseconds) + " ms");
    }
    return result;
  }

  // --- components started through launchers ----------------------------------
  // Asks the launchers to start the PEIS of `config` that are not running
  // (the planner had them from LiveModel::launchable, with id 0) and waits
  // until each has joined and introspection has its tuples, or its launcher
  // says it failed, or options.launchWait passes. Returns whether it asked
  // for any; one that did not come is a failed part (planned without).
  bool launchFor(const Configuration& config, const LiveModel& live) {
    std::vector<std::string> needed;
    for (const auto& i : config.instances) {
      if (i.peisId != 0 || std::find(needed.begin(), needed.end(), i.peis) != needed.end())
        continue;
      if (const auto* p = live.findByName(i.peis); p && p->alive) continue;
      needed.push_back(i.peis);
    }
    if (needed.empty()) return false;
    const auto until = Clock::now() + options.launchWait;
    std::vector<std::string> asked;
    for (const auto& name : needed) {
      const auto where = live.launchable(name);
      if (!where) {
        launchFailed(name, "no launcher offers it any more");
        continue;
      }
      const Launched l{where->launcher->id, where->launcher->name, where->component};
      const auto key = conventions::launchKey(l.component, conventions::kLaunchReqState);
      events.record("launch", "asking launcher '" + l.launcherName + "' (" +
                                  std::to_string(l.launcher) + ") to start component " +
                                  l.component + " for PEIS '" + name + "': " + key + " = on");
      try {
        kernel.set(l.launcher, key, std::string(conventions::kLaunchOn));
        launched[name] = l;
        asked.push_back(name);
      } catch (const Error& e) {
        launchFailed(name, std::string("the launcher did not take the request: ") + e.what());
      }
    }
    for (const auto& name : asked) {
      std::string why =
          "its PEIS did not join within " + std::to_string(options.launchWait.count()) + " ms";
      bool ended = false;  // the launcher failed it, or is gone: nothing to stop later
      const auto joined = waitUntil(until, [&] {
        const auto now = introspector.snapshot();
        const auto* p = now.findByName(name);
        if (p && p->alive && p->descriptor && introspector.complete()) return true;
        const auto& l = launched[name];
        if (const auto* launcher = now.find(l.launcher)) {
          const auto it = launcher->launches.find(l.component);
          if (it != launcher->launches.end() &&
              it->second.currState == conventions::kLaunchFailed) {
            why = "its launcher says: " + it->second.status;
            ended = true;
            return true;
          }
        } else {
          why = "its launcher is gone";
          ended = true;
          return true;
        }
        return false;
      });
      const auto now = introspector.snapshot();
      const auto* p = now.findByName(name);
      if (joined && p && p->alive && p->descriptor) {
        events.record("launched", "PEIS '" + name + "' (" + std::to_string(p->id) +
                                      ") of component " + launched[name].component +
                                      " runs, started by launcher '" + launched[name].launcherName +
                                      "'");
      } else {
        launchFailed(name, why);
        // A failed component stays `failed` (its status says why); one that is
        // slow to join is switched off again by stopUnused when not deployed.
        if (ended) launched.erase(name);
      }
    }
    return true;
  }

  void launchFailed(const std::string& peisName, const std::string& why) {
    events.record("launch-failed", "PEIS '" + peisName + "': " + why);
    Failure f{FailureKind::StaleInput, {}, 0, 0, "could not be started: " + why};
    f.instance.peis = peisName;
    failed.add(f, Clock::now());
  }

  // Stops the components this configurator started that `config` no longer uses.
  void stopUnused(const Configuration& config) {
    for (auto it = launched.begin(); it != launched.end();) {
      const auto& [name, l] = *it;
      const bool used = std::any_of(config.instances.begin(), config.instances.end(),
                                    [&](const ActiveInstance& i) { return i.peis == name; });
      if (used) {
        ++it;
        continue;
      }
      const auto key = conventions::launchKey(l.component, conventions::kLaunchReqState);
      events.record("stop", "no configuration uses PEIS '" + name + "': asking launcher '" +
                                l.launcherName + "' to stop component " + l.component + ": " + key +
                                " = off");
      kernel.setAsync(l.launcher, key, std::string(conventions::kLaunchOff), {},
                      [](const std::optional<Error>&, std::uint64_t) {});
      it = launched.erase(it);
    }
  }

  // Waits, woken by introspection, until `done` holds, the configurator
  // stops, or `until` passes; returns whether `done` held.
  bool waitUntil(Clock::time_point until, const std::function<bool()>& done) {
    while (true) {
      if (done()) return true;
      std::unique_lock lock(mu);
      if (stopping || Clock::now() >= until) return false;
      wake.wait_until(lock, std::min(until, Clock::now() + milliseconds(200)),
                      [this] { return woken || stopping; });
      woken = false;
    }
  }

  bool reachable(int peis) const {
    for (const auto& p : kernel.peers())
      if (p.id == peis) return true;
    return false;
  }

  std::string avoiding() const {
    const auto selectors = failed.selectors();
    if (selectors.empty()) return "";
    std::vector<std::string> names;
    for (const auto& s : selectors) names.push_back(s.toString());
    return ", avoiding " + joined(names, ", ");
  }

  static std::string sourceList(const std::vector<GoalSource>& sources) {
    std::vector<std::string> parts;
    for (const auto& s : sources) {
      std::string goals;
      for (char c : s.text) goals += c == '\n' ? ' ' : c;
      while (!goals.empty() && goals.back() == ' ') goals.pop_back();
      parts.push_back(s.origin() + " [" + goals + "]");
    }
    return joined(parts, ", ");
  }

  void correctDrift(const LiveModel& live, Clock::time_point now) {
    // A configuration being repaired is not put back: the repair replaces it.
    if (!deployed || !monitor.active() || repairPending) return;
    // What deploy leaves alone (the PEIS of failed parts) is no drift either:
    // else a PEIS in error that keeps its old switch-on is "put back" forever.
    const auto changes =
        deployer.pendingChanges(deployed->configuration, live, failedPeisIds(live));
    if (changes.empty()) {
      driftSince.reset();
      return;
    }
    if (now < driftQuietUntil) return;
    if (!driftSince) driftSince = now;
    if (now - *driftSince < options.driftHold) return;
    std::size_t writes = 0, records = 0;
    for (const auto& c : changes) {
      writes += c.writes.size();
      records += c.recordChanges() ? 1 : 0;
    }
    events.record("drift", std::to_string(writes) + " deployed tuple(s) and " +
                               std::to_string(records) +
                               " record(s) differ from what was deployed (another writer, a PEIS "
                               "restarted, a deployment cut short): putting them back");
    const auto result = deploy(deployed->configuration, live);
    // Nothing could be put back (a PEIS that does not answer): look again later.
    if (!result.ok || result.writes == 0) driftQuietUntil = now + options.grace;
    // A PEIS of the configuration is gone: that is for a repair.
    if (!result.ok && result.failedPeis != 0) {
      repairPending = true;
      repairRetryAt = now;
    }
    driftSince.reset();
  }

  // --- published tuples -------------------------------------------------------------
  void publishModel(const LiveModel& live, std::uint64_t version, Clock::time_point now) {
    if (version == publishedVersion || now - lastPublish < kPublishEvery) return;
    publishedVersion = version;
    lastPublish = now;
    WriteOptions yamlOptions;
    yamlOptions.mimetype = "application/yaml";
    kernel.set("model.live", live.toYaml(), yamlOptions);
    kernel.set("model.yaml", live.toModel(options.costs, options.overrides).toYaml(), yamlOptions);
  }

  // A goal tuple written again with the same goals (the executor posts a
  // step's needs that the previous step had too) gets the same answer for
  // its new seqno, without planning again.
  void refreshStatusSeqnos(const std::vector<GoalSource>& sources) {
    auto lines = statusLines;
    bool changed = false;
    for (auto& line : lines) {
      for (const auto& s : sources) {
        if (s.owner == line.owner && s.key == line.key && s.seqno != line.seqno) {
          line.seqno = s.seqno;
          changed = true;
        }
      }
    }
    if (changed) publishStatus(lines);
  }

  void publishStatus(const std::vector<GoalStatusLine>& lines) {
    statusLines = lines;
    auto sorted = lines;
    std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
      return std::tie(a.owner, a.key) < std::tie(b.owner, b.key);
    });
    const auto text = formatGoalStatus(sorted);
    if (text == publishedStatus) return;
    publishedStatus = text;
    kernel.set(std::string(kGoalStatusKey), text);
  }

  void publishDeployed(std::uint64_t generation, const std::vector<GoalSource>& sources) {
    std::string text = "generation " + std::to_string(generation) + "\n";
    for (const auto& s : sources) {
      for (const auto& line : parseGoalTuple(s.text, s.origin()).goals.information)
        text += "goal " + line.toString() + "  (" + line.origin + ")\n";
    }
    text += formatText(*deployed);
    kernel.set("config.deployed", text);
  }
};

Configurator::Configurator(Kernel& kernel, ConfiguratorOptions options)
    : impl_(std::make_unique<Impl>(kernel, std::move(options))) {
  impl_->start();
}

Configurator::~Configurator() { impl_->stop(); }

}  // namespace peis::meta
