// peis-config's online subcommands (see config_online.h).
#include "programs/config_online.h"

#include <algorithm>
#include <charconv>
#include <csignal>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "deploy/deployer.h"
#include "introspect/introspector.h"
#include "monitor/events.h"
#include "monitor/goal_tuples.h"
#include "peis/conventions.h"
#include "peis/error.h"
#include "peis/kernel.h"
#include "peis/key.h"
#include "peis/meta/planner.h"
#include "planner/json.h"

namespace peis::meta::cli {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

Options peisOptions;

milliseconds toMs(double seconds) { return milliseconds(static_cast<long>(seconds * 1000)); }

double secondsValue(const std::string& option, const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end || !(value >= 0) || value > 86400)
    throw std::invalid_argument(option + " takes seconds from 0 to 86400");
  return value;
}

// The options one subcommand takes: flags and options with a value.
struct ArgSpec {
  std::vector<std::string> flags;
  std::vector<std::string> valued;
};
struct ParsedArgs {
  std::map<std::string, std::string> values;
  std::vector<std::string> positional;
  bool has(const std::string& name) const { return values.count(name) > 0; }
  std::string get(const std::string& name, const std::string& otherwise = "") const {
    auto it = values.find(name);
    return it == values.end() ? otherwise : it->second;
  }
};
ParsedArgs parseArgs(const std::vector<std::string>& args, const ArgSpec& spec) {
  ParsedArgs parsed;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const auto& a = args[i];
    if (a.rfind("--", 0) != 0 || a == "--") {
      parsed.positional.push_back(a);
      continue;
    }
    if (std::find(spec.flags.begin(), spec.flags.end(), a) != spec.flags.end()) {
      parsed.values[a] = "";
    } else if (std::find(spec.valued.begin(), spec.valued.end(), a) != spec.valued.end()) {
      if (i + 1 >= args.size()) throw std::invalid_argument(a + " needs a value");
      parsed.values[a] = args[++i];
    } else {
      throw std::invalid_argument("unknown option " + a);
    }
  }
  return parsed;
}

// A tool PEIS in the ecology with introspection, settled.
struct Session {
  std::unique_ptr<Kernel> kernel;
  std::unique_ptr<Introspector> introspector;
  LiveModel live;

  // `named`: PEIS the command's goals name (consumers, avoided PEIS); the
  // model waits for them too, within the same wait (a fresh tool PEIS may
  // have settled before it heard of every PEIS).
  explicit Session(double waitSeconds, const std::vector<std::string>& named = {}) {
    Options o = peisOptions;
    o.tool = true;
    kernel = std::make_unique<Kernel>(o);
    introspector = std::make_unique<Introspector>(*kernel);
    const auto deadline = Clock::now() + toMs(waitSeconds);
    const auto left = [&] {
      return std::max(std::chrono::duration_cast<milliseconds>(deadline - Clock::now()),
                      milliseconds(1));
    };
    // Someone must have been heard before "nothing changed for a while" means anything.
    while (kernel->peers().size() < 2 && Clock::now() < deadline)
      std::this_thread::sleep_for(milliseconds(5));
    introspector->waitSettled(left());
    live = introspector->snapshot();
    // A PEIS the kernel knows may still be missing from the model until its
    // tuples arrived: wait for the model, not only the name.
    for (const auto& name : named) {
      while (!live.findByName(name) && Clock::now() < deadline) {
        if (!kernel->waitForPeer(name, left())) break;  // planning names it unknown
        introspector->waitSettled(left());
        live = introspector->snapshot();
        if (!live.findByName(name)) std::this_thread::sleep_for(milliseconds(10));
      }
    }
  }

  // The active configurator, if one is alive.
  std::optional<int> configurator() const {
    std::optional<int> standby;
    for (const auto& p : live.peis) {
      if (!p.alive || !p.configurator) continue;
      const auto role = kernel->get(p.id, "config.configurator");
      if (role && role->data == "active") return p.id;
      standby = p.id;
    }
    return standby;
  }

  std::string nameOf(int id) const {
    const auto* p = live.find(id);
    return p ? p->name : std::to_string(id);
  }
};

std::string goalLine(const InformationGoal& g) { return g.toString(); }

// The PEIS that goals name by name: their consumers and the avoided PEIS.
std::vector<std::string> peisNamed(const Goals& goals) {
  std::vector<std::string> names;
  for (const auto& g : goals.information)
    if (!g.consumerPeis.empty()) names.push_back(g.consumerPeis);
  for (const auto& p : goals.constraints.avoidPeis) names.push_back(p);
  return names;
}

}  // namespace

void setPeisOptions(const Options& options) { peisOptions = options; }

std::vector<std::string> goalLines(const std::vector<std::string>& goalArgs,
                                   const std::string& goalsFile) {
  // Checked here, so a typo is a usage error before anything is written.
  Goals::fromArguments(goalArgs);
  std::vector<std::string> lines = goalArgs;
  if (!goalsFile.empty()) {
    const auto goals = Goals::fromFile(goalsFile);
    for (const auto& g : goals.information) lines.push_back(goalLine(g));
    for (const auto& g : goals.run) lines.push_back("run:" + g.instance.toString());
    for (const auto& p : goals.constraints.avoidPeis) lines.push_back("avoid:" + p);
    for (const auto& s : goals.constraints.avoid) lines.push_back("avoid:" + s.toString());
    for (const auto& s : goals.constraints.prefer) lines.push_back("prefer:" + s.toString());
  }
  return lines;
}

// --- model ---------------------------------------------------------------------------

int model(const std::vector<std::string>& args) {
  const auto a = parseArgs(args, {{"--json", "--yaml", "--local"}, {"--save", "--wait"}});
  if (!a.positional.empty()) throw std::invalid_argument("model takes no arguments");
  const double wait = a.has("--wait") ? secondsValue("--wait", a.get("--wait")) : 3.0;
  Session session(wait);
  LiveModel live = session.live;
  std::string source = "introspected by this command";
  if (const auto cfg = session.configurator(); cfg && !a.has("--local")) {
    if (const auto published = session.kernel->get(*cfg, "model.live", toMs(wait))) {
      live = LiveModel::fromYaml(published->data, session.nameOf(*cfg) + ".model.live");
      source = "published by configurator " + session.nameOf(*cfg);
    }
  }
  const Model model = live.toModel();
  if (a.has("--save")) {
    std::ofstream out(a.get("--save"));
    if (!out) throw std::invalid_argument("cannot write " + a.get("--save"));
    out << model.toYaml();
    std::cout << "saved the model of " << model.peis.size() << " PEIS to " << a.get("--save")
              << " (" << source << ")\n";
    return 0;
  }
  if (a.has("--json")) {
    std::cout << live.toJson() << "\n";
  } else if (a.has("--yaml")) {
    std::cout << model.toYaml();
  } else {
    std::cout << "model of ecology '" << peisOptions.ecology << "', " << live.peis.size()
              << " PEIS (" << source << ")\n"
              << live.toText();
  }
  return 0;
}

// --- plan on the live model --------------------------------------------------------

int planLive(const std::vector<std::string>& goalArgs, const std::string& goalsFile, bool json,
             long timeLimitMs, bool first, double waitSeconds) {
  auto goals = Goals::fromArguments(goalArgs);
  // The file's constraints (avoid, prefer) too, not only its goals.
  if (!goalsFile.empty()) mergeGoals(goals, Goals::fromFile(goalsFile));
  if (goals.empty()) throw std::invalid_argument("no goal given");
  Session session(waitSeconds);
  ConfigurationPlanner planner(session.live.toModel());
  PlanOptions options;
  options.timeLimit = milliseconds(timeLimitMs);
  options.firstSolutionOnly = first;
  const auto result = planner.plan(goals, options);
  std::cout << (json ? formatJson(result) + "\n" : formatText(result));
  return result.ok() ? 0 : 1;
}

// --- apply and withdraw ---------------------------------------------------------------

namespace {

// Waits for the configurator's answer to goal tuple (cfg, key) at `seqno`.
std::optional<GoalStatusLine> awaitAnswer(Session& session, int cfg, const std::string& key,
                                          std::uint64_t seqno, milliseconds timeout,
                                          bool acceptPending = false) {
  session.kernel->subscribe(Pattern::exact(cfg, std::string(kGoalStatusKey)));
  session.kernel->subscribe(Pattern::exact(cfg, "config.deployed"));
  const auto until = Clock::now() + timeout;
  std::optional<GoalStatusLine> last;
  while (Clock::now() < until) {
    if (const auto t = session.kernel->get(cfg, std::string(kGoalStatusKey))) {
      for (const auto& line : parseGoalStatus(t->data)) {
        if (line.owner != cfg || line.key != key || line.seqno < seqno) continue;
        last = line;
        if (line.state != GoalState::Pending || acceptPending) return line;
      }
    }
    std::this_thread::sleep_for(milliseconds(10));
  }
  return last;
}

}  // namespace

int apply(const std::vector<std::string>& args) {
  const auto a =
      parseArgs(args, {{"--json", "--dry-run"}, {"--goals", "--as", "--wait", "--timeout"}});
  const auto lines = goalLines(a.positional, a.get("--goals"));
  if (lines.empty()) throw std::invalid_argument("no goal given");
  const std::string label = a.get("--as", "cli");
  if (const auto problem = keyProblem(std::string(kGoalPrefix) + label))
    throw std::invalid_argument("--as '" + label + "': " + *problem);
  const double wait = a.has("--wait") ? secondsValue("--wait", a.get("--wait")) : 3.0;
  const double timeout = a.has("--timeout") ? secondsValue("--timeout", a.get("--timeout")) : 15.0;
  Goals goals = Goals::fromArguments(lines);
  Session session(wait, peisNamed(goals));
  const auto cfg = session.configurator();
  if (cfg && !a.has("--dry-run")) {
    // Through the running configurator: post the goals as its goal tuple.
    const std::string key = std::string(kGoalPrefix) + label;
    const auto written = session.kernel->set(*cfg, key, formatGoalTuple(lines));
    const auto answer = awaitAnswer(session, *cfg, key, written.seqno, toMs(timeout));
    std::cout << "goals posted to configurator " << session.nameOf(*cfg) << " as " << key << "\n";
    if (!answer) {
      std::cout << "no answer from the configurator within " << timeout << " s\n";
      return 1;
    }
    std::cout << toString(answer->state) << (answer->reason.empty() ? "" : ": " + answer->reason)
              << "\n";
    if (answer->state == GoalState::Deployed) {
      if (const auto d = session.kernel->get(*cfg, "config.deployed", milliseconds(2000)))
        std::cout << d->data;
    }
    return answer->state == GoalState::Deployed ? 0 : 1;
  }
  // No configurator: plan here and deploy once (nobody watches it afterwards).
  ConfigurationPlanner planner(session.live.toModel());
  PlanOptions options;
  options.timeLimit = milliseconds(1000);
  const auto result = planner.plan(goals, options);
  std::cout << (a.has("--json") ? formatJson(result) + "\n" : formatText(result));
  if (!result.ok()) return 1;
  // A PEIS that a launcher would start (id 0): only the configurator starts components.
  for (const auto& i : result.configuration.instances) {
    if (i.peisId != 0) continue;
    const auto where = session.live.launchable(i.peis);
    std::cout << "PEIS '" << i.peis << "' does not run";
    if (where)
      std::cout << "; its launcher '" << where->launcher->name << "' starts it with: peis set "
                << where->launcher->name << "."
                << conventions::launchKey(where->component, conventions::kLaunchReqState) << " on";
    std::cout << " (a running peis-configurator does that by itself)\n";
    return 1;
  }
  Deployer deployer(*session.kernel);
  if (a.has("--dry-run")) {
    const auto changes = deployer.pendingChanges(result.configuration, session.live);
    std::cout << (changes.empty() ? "nothing to change\n" : "would write:\n");
    for (const auto& c : changes)
      for (const auto& w : c.writes)
        std::cout << "  " << session.nameOf(w.peis) << "." << w.key << " = " << w.value << "\n";
    return 0;
  }
  const auto deployed = deployer.deploy(result.configuration, session.live);
  for (const auto& w : deployed.warnings) std::cout << "warning: " << w << "\n";
  if (!deployed.ok) {
    std::cout << "deployment failed: " << deployed.error << "\n";
    return 1;
  }
  if (deployed.unchanged) {
    std::cout << "deployed already: nothing to change\n";
  } else {
    char ms[32];
    std::snprintf(ms, sizeof ms, "%.1f", deployed.milliseconds);
    std::cout << "deployed generation " << deployed.generation << ": " << deployed.writes
              << " writes on " << deployed.peisTouched << " PEIS in " << ms
              << " ms (no configurator runs: nobody watches it)\n";
  }
  return 0;
}

int withdraw(const std::vector<std::string>& args) {
  const auto a = parseArgs(args, {{}, {"--as", "--wait", "--timeout"}});
  if (!a.positional.empty()) throw std::invalid_argument("withdraw takes no goals (use --as)");
  const std::string key = std::string(kGoalPrefix) + a.get("--as", "cli");
  const double wait = a.has("--wait") ? secondsValue("--wait", a.get("--wait")) : 3.0;
  Session session(wait);
  const auto cfg = session.configurator();
  if (!cfg) {
    std::cerr << "peis-config: no configurator in the ecology\n";
    return 1;
  }
  session.kernel->set(*cfg, key, "");
  std::cout << "withdrew " << session.nameOf(*cfg) << "." << key << "\n";
  return 0;
}

// --- show ------------------------------------------------------------------------------

int show(const std::vector<std::string>& args) {
  const auto a = parseArgs(args, {{"--json"}, {"--wait"}});
  if (!a.positional.empty()) throw std::invalid_argument("show takes no arguments");
  const double wait = a.has("--wait") ? secondsValue("--wait", a.get("--wait")) : 3.0;
  Session session(wait);
  struct Row {
    std::string peis, key, value;
  };
  std::vector<Row> rows;
  std::set<std::uint64_t> generations;
  std::vector<std::string> busy;
  for (const auto& p : session.live.peis) {
    if (!p.alive) continue;
    const auto record = OwnedRecord::parse(p.owned);
    if (!record.keys.empty()) generations.insert(record.generation);
    for (const auto& key : record.keys) {
      std::string value;
      if (auto l = p.links.find(key); l != p.links.end()) {
        value = l->second;
        const auto canonical = session.live.canonicalTarget(value);
        const auto dot = canonical.find('.');
        int target = 0;
        if (dot != std::string::npos &&
            std::from_chars(canonical.data(), canonical.data() + dot, target).ptr ==
                canonical.data() + dot)
          value = session.nameOf(target) + canonical.substr(dot);
      } else if (auto t = session.kernel->get(p.id, key)) {
        value = t->data;
      }
      rows.push_back({p.name, key, value});
    }
    if (const auto lock = lastLockLine(p.lock); lock && lock->deploying)
      busy.push_back(p.name + " (generation " + std::to_string(lock->generation) + " by PEIS " +
                     std::to_string(lock->holder) + ")");
  }
  const auto cfg = session.configurator();
  std::string summary;
  if (cfg) {
    if (const auto d = session.kernel->get(*cfg, "config.deployed", toMs(std::min(wait, 2.0))))
      summary = d->data;
  }
  if (a.has("--json")) {
    using json::quote;
    std::cout << "{\"generations\":[";
    bool first = true;
    for (auto g : generations) {
      std::cout << (first ? "" : ",") << g;
      first = false;
    }
    std::cout << "],\"tuples\":[";
    for (std::size_t i = 0; i < rows.size(); ++i)
      std::cout << (i ? "," : "") << "{\"peis\":" << quote(rows[i].peis)
                << ",\"key\":" << quote(rows[i].key) << ",\"value\":" << quote(rows[i].value)
                << "}";
    std::cout << "],\"deploying\":[";
    for (std::size_t i = 0; i < busy.size(); ++i) std::cout << (i ? "," : "") << quote(busy[i]);
    std::cout << "],\"configurator\":" << (cfg ? quote(session.nameOf(*cfg)) : "null")
              << ",\"summary\":" << quote(summary) << "}\n";
    return 0;
  }
  if (rows.empty()) {
    std::cout << "nothing deployed\n";
  } else {
    std::cout << "deployed (generation";
    for (auto g : generations) std::cout << " " << g;
    std::cout << "):\n";
    for (const auto& r : rows) {
      if (isMetaKey(r.key)) {
        std::cout << "  " << r.peis << "." << r.key << " <- "
                  << (r.value.empty() ? "(nowhere)" : r.value) << "\n";
      } else {
        std::cout << "  " << r.peis << "." << r.key << " = " << r.value << "\n";
      }
    }
    if (generations.size() > 1)
      std::cout << "note: records of several generations (a deployment is under way or was cut "
                   "short; the configurator completes it)\n";
  }
  for (const auto& b : busy) std::cout << "being deployed: " << b << "\n";
  if (cfg) {
    std::cout << "configurator " << session.nameOf(*cfg);
    if (!summary.empty())
      std::cout << ":\n" << summary;
    else
      std::cout << ": nothing deployed by it\n";
  } else {
    std::cout << "no configurator runs\n";
  }
  return 0;
}

// --- events ----------------------------------------------------------------------------

namespace {
volatile std::sig_atomic_t interrupted = 0;
void onSignal(int) { interrupted = 1; }
}  // namespace

int events(const std::vector<std::string>& args) {
  const auto a =
      parseArgs(args, {{"--follow", "--json"}, {"--from", "--wait", "--count", "--timeout"}});
  if (!a.positional.empty()) throw std::invalid_argument("events takes no arguments");
  const double wait = a.has("--wait") ? secondsValue("--wait", a.get("--wait")) : 3.0;
  const double timeout = a.has("--timeout") ? secondsValue("--timeout", a.get("--timeout")) : 0;
  long count = 0;
  if (a.has("--count")) {
    const auto text = a.get("--count");
    if (std::from_chars(text.data(), text.data() + text.size(), count).ptr !=
            text.data() + text.size() ||
        count < 1)
      throw std::invalid_argument("--count takes a number >= 1");
  }
  Session session(wait);
  std::optional<int> cfg;
  if (a.has("--from")) {
    cfg = session.kernel->resolveOwner(a.get("--from"));
  } else {
    cfg = session.configurator();
  }
  if (!cfg) {
    std::cerr << "peis-config: no configurator in the ecology\n";
    return 1;
  }
  std::mutex mu;
  std::map<std::uint64_t, ConfigEvent> pending;
  std::uint64_t printed = 0;
  long lines = 0;
  auto print = [&](const ConfigEvent& e) {
    if (a.has("--json")) {
      std::cout << "{\"number\":" << e.number
                << ",\"time_us\":" << e.time.time_since_epoch().count()
                << ",\"kind\":" << json::quote(e.kind) << ",\"text\":" << json::quote(e.text) << "}"
                << std::endl;
    } else {
      std::cout << e.format() << std::endl;
    }
    ++lines;
  };
  auto take = [&](const Tuple& t) {
    const auto n = eventNumber(t.key);
    if (!n) return;
    std::lock_guard lock(mu);
    if (*n <= printed) return;
    pending[*n] = ConfigEvent::parse(*n, t.ts_user, t.data);
  };
  const Pattern pattern(std::string(kEventPrefix) + "*", *cfg);
  // The callback uses this function's locals: removed before they go.
  struct Unregister {
    Kernel& kernel;
    CallbackHandle handle;
    ~Unregister() { kernel.removeCallback(handle); }
  } unregister{*session.kernel, session.kernel->onChange(pattern, take)};
  session.kernel->subscribe(pattern);
  // What is there now: wait until the configurator's key list is all here.
  const auto until = Clock::now() + toMs(wait);
  while (Clock::now() < until) {
    const auto keys = session.kernel->get(*cfg, special::kAllKeys, milliseconds(100));
    std::size_t expected = 0;
    if (keys) {
      std::istringstream in(keys->data);
      for (std::string k; in >> k;) expected += eventNumber(k) ? 1 : 0;
    }
    if (session.kernel->find(pattern).size() >= expected && keys) break;
    std::this_thread::sleep_for(milliseconds(10));
  }
  for (const auto& t : session.kernel->find(pattern)) take(t);
  auto flush = [&] {
    std::lock_guard lock(mu);
    for (auto it = pending.begin(); it != pending.end() && (count == 0 || lines < count);) {
      print(it->second);
      printed = it->first;
      it = pending.erase(it);
    }
  };
  flush();
  if (!a.has("--follow")) return 0;
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  const auto stopAt = timeout > 0 ? Clock::now() + toMs(timeout) : Clock::time_point::max();
  while (!interrupted && (count == 0 || lines < count) && Clock::now() < stopAt) {
    std::this_thread::sleep_for(milliseconds(20));
    flush();
  }
  return count > 0 && lines < count ? 1 : 0;
}

}  // namespace peis::meta::cli
