// peis-bench-configurator: the meta-level's runtime measured with real
// processes over loopback (docs/performance.md, "Deployment and repair").
//
//   deploy  A 20-link configuration across 10 PEIS processes (peis-synthetic):
//           deployed from nothing, switched to another 20-link configuration
//           (every link re-pointed, the old ones switched off), and deployed
//           again unchanged (the idempotency check), by Deployer in this process.
//   repair  A consumer (this process) fed by a cheap producer; a dearer one
//           stands by; peis-configurator watches. Each trial kills the cheap
//           producer (kill -9, or SIGSTOP: a hung host) and times, from the
//           configurator's event tuples, detection (kill -> failure seen),
//           planning and deployment (their own durations), and, at the
//           consumer, the first fresh value from the new producer. An unrelated
//           link (thermometer -> thermostat) must never be re-pointed.
//   soak    Both cores loaded; the producer frozen (SIGSTOP) for 60 % of the
//           liveness period, again and again: false repairs are counted.
//
//   peis-bench-configurator deploy [--trials N]
//   peis-bench-configurator repair [--trials N] [--liveness-ms MS] [--freeze]
//   peis-bench-configurator soak [--trials N] [--liveness-ms MS]
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "bench_stats.h"
#include "deploy/deployer.h"
#include "introspect/introspector.h"
#include "monitor/events.h"
#include "peis/component.h"
#include "peis/kernel.h"
#include "peis/meta/planner.h"

extern char** environ;

namespace {

using namespace std::chrono_literals;
using peis::bench::Clock;
using peis::bench::percentiles;

// A program of the build, started as a child that dies with the benchmark,
// ended by pid.
class Program {
 public:
  Program(const std::string& path, std::vector<std::string> args,
          const std::vector<std::string>& extraEnvironment) {
    std::vector<char*> argv;
    args.insert(args.begin(), path);
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> envStrings;
    for (char** e = environ; *e; ++e) envStrings.emplace_back(*e);
    for (const auto& e : extraEnvironment) envStrings.push_back(e);
    std::vector<char*> envp;
    for (auto& e : envStrings) envp.push_back(e.data());
    envp.push_back(nullptr);
    const pid_t parent = getpid();
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("cannot start " + path);
    if (pid_ == 0) {
      // Dies with the benchmark, however it ends.
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != parent) _exit(1);
      const int null = open("/dev/null", O_WRONLY);
      dup2(null, 1);
      dup2(null, 2);
      execve(path.c_str(), argv.data(), envp.data());
      _exit(127);
    }
  }
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;
  ~Program() { stop(SIGKILL); }
  void signal(int sig) {
    if (pid_ > 0) ::kill(pid_, sig);
  }
  void stop(int sig = SIGTERM) {
    if (pid_ <= 0) return;
    ::kill(pid_, sig);
    if (sig == SIGSTOP) return;
    ::kill(pid_, SIGCONT);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
};

std::string ecologyName(const std::string& what) {
  std::random_device device;
  return "bench-cfg-" + what + "-" + std::to_string(getpid()) + "-" +
         std::to_string(device() % 100000);
}

bool waitUntil(const std::function<bool()>& condition, std::chrono::milliseconds deadline) {
  const auto until = Clock::now() + deadline;
  while (!condition()) {
    if (Clock::now() >= until) return condition();
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

std::string writeFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
  return path.string();
}

std::string fixed(double value, int decimals = 1) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
  return buf;
}

// p50, p99 and max, as table cells (`separator` " | ") or in one cell (" / ").
std::string row(const std::vector<double>& values, const std::string& separator = " | ") {
  if (values.empty()) return "-";
  const auto p = percentiles(values);
  double max = 0;
  for (double v : values) max = std::max(max, v);
  return fixed(p.p50, 2) + separator + fixed(p.p99, 2) + separator + fixed(max, 2);
}

peis::Options benchOptions(const std::string& ecology, std::chrono::milliseconds liveness) {
  peis::Options o;
  o.ecology = ecology;
  o.name = "bench";
  o.liveness = liveness;
  return o;
}

// --- deploy ------------------------------------------------------------------------------

int deployBench(int trials) {
  const auto ecology = ecologyName("deploy");
  const auto dir = std::filesystem::temp_directory_path() / ecology;
  std::filesystem::create_directories(dir);
  const std::vector<std::string> env = {"PEIS_ECOLOGY=" + ecology, "PEIS_LOG=quiet"};
  std::vector<std::unique_ptr<Program>> nodes;
  for (int i = 0; i < 10; ++i) {
    const auto descriptor =
        writeFile(dir / ("n" + std::to_string(i) + ".yaml"),
                  "component: node" + std::to_string(i) +
                      "\nfunctionalities:\n  - name: produce\n    outputs:\n"
                      "      - {name: x, type: t" +
                      std::to_string(i) + ", key: t" + std::to_string(i) +
                      "}\n      - {name: y, type: t" + std::to_string(i + 10) + ", key: t" +
                      std::to_string(i + 10) + "}\n    activation: producing\n    cost: 1\n");
    nodes.push_back(
        std::make_unique<Program>(PEIS_SYNTHETIC_PATH,
                                  std::vector<std::string>{"--peis-name", "n" + std::to_string(i),
                                                           "--descriptor", descriptor},
                                  env));
  }
  peis::Kernel kernel(benchOptions(ecology, 2000ms));
  peis::meta::Introspector introspector(kernel);
  const bool all = waitUntil(
      [&] {
        const auto live = introspector.snapshot();
        int described = 0;
        for (const auto& p : live.peis) described += p.alive && p.descriptor ? 1 : 0;
        return described == 10 && introspector.complete();
      },
      60s);
  if (!all) {
    std::cerr << "peis-bench-configurator: the 10 PEIS did not all join\n";
    return 1;
  }
  peis::meta::ConfigurationPlanner planner(introspector.snapshot().toModel());
  auto goalsFor = [](int shift) {
    std::vector<std::string> args;
    for (int j = 0; j < 20; ++j)
      args.push_back("t" + std::to_string(j) + "@n" + std::to_string((j % 10 + shift) % 10) +
                     ".mi-in" + std::to_string(j));
    return peis::meta::Goals::fromArguments(args);
  };
  const auto a = planner.plan(goalsFor(1));
  const auto b = planner.plan(goalsFor(2));
  if (!a.ok() || !b.ok() || a.configuration.links.size() != 20) {
    std::cerr << "peis-bench-configurator: no 20-link configuration\n";
    return 1;
  }
  peis::meta::Deployer deployer(kernel);
  auto deploy = [&](const peis::meta::Configuration& c, std::size_t& writes) {
    // The cache must hold the values the last deployment wrote before the
    // next diff: wait until nothing is pending.
    const auto start = Clock::now();
    const auto result = deployer.deploy(c, introspector.snapshot());
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    if (!result.ok) throw std::runtime_error(result.error);
    writes = result.writes;
    waitUntil([&] { return deployer.pendingChanges(c, introspector.snapshot()).empty(); }, 10s);
    return ms;
  };
  std::vector<double> first, switched, unchanged;
  std::size_t firstWrites = 0, switchWrites = 0, sameWrites = 0;
  first.push_back(deploy(a.configuration, firstWrites));
  for (int t = 0; t < trials; ++t) {
    switched.push_back(deploy(t % 2 == 0 ? b.configuration : a.configuration, switchWrites));
    unchanged.push_back(deploy(t % 2 == 0 ? b.configuration : a.configuration, sameWrites));
  }
  std::cout << "Deployment: a 20-link configuration across 10 PEIS processes (peis-synthetic), "
               "deployed by peis::meta::Deployer from an eleventh process; "
            << trials << " switches.\n\n"
            << "| deployment | tuples written | p50 (ms) | p99 (ms) | max (ms) |\n"
            << "|---|---|---|---|---|\n"
            << "| from nothing (20 links, 10 activations) | " << firstWrites << " | " << row(first)
            << " |\n"
            << "| switch to another 20-link configuration | " << switchWrites << " | "
            << row(switched) << " |\n"
            << "| the same again (nothing to change) | " << sameWrites << " | " << row(unchanged)
            << " |\n\n";
  std::filesystem::remove_all(dir);
  return 0;
}

// --- repair and soak --------------------------------------------------------------------

struct RepairSetup {
  std::string ecology;
  std::chrono::milliseconds liveness;
  std::vector<std::string> env;
  std::unique_ptr<peis::Kernel> kernel;
  std::unique_ptr<peis::Component> consumer;
  std::unique_ptr<Program> dear, configurator, thermometer, thermostat;
  peis::PeisId cfg = 0, dearId = 0, thermostatId = 0;

  std::mutex mu;
  // Arrivals at the consumer's input: (producer, time).
  std::vector<std::pair<peis::PeisId, Clock::time_point>> arrivals;

  RepairSetup(std::chrono::milliseconds live, const std::string& tag)
      : ecology(ecologyName(tag)), liveness(live) {
    env = {"PEIS_ECOLOGY=" + ecology, "PEIS_LOG=quiet",
           "PEIS_LIVENESS_MS=" + std::to_string(liveness.count())};
    kernel = std::make_unique<peis::Kernel>(benchOptions(ecology, liveness));
    consumer = std::make_unique<peis::Component>(
        *kernel, "follower",
        peis::Descriptor::fromFile(std::string(PEIS_SOURCE_DIR) +
                                   "/tests/meta/descriptors/consumer.yaml"));
    consumer->input("position", 200ms, [this](const peis::Tuple& t) {
      std::lock_guard lock(mu);
      arrivals.emplace_back(t.owner, Clock::now());
    });
    consumer->start();
    const std::string descriptors = std::string(PEIS_SOURCE_DIR) + "/tests/meta/descriptors/";
    auto synthetic = [&](const std::string& name, const std::string& file) {
      return std::make_unique<Program>(
          PEIS_SYNTHETIC_PATH,
          std::vector<std::string>{"--peis-name", name, "--descriptor", descriptors + file,
                                   "--period-ms", "20", "--freshness-ms", "200"},
          env);
    };
    dear = synthetic("pb", "position-dear.yaml");
    thermometer = synthetic("thermometer", "thermometer.yaml");
    thermostat = synthetic("thermostat", "thermostat.yaml");
    configurator = std::make_unique<Program>(
        PEIS_CONFIGURATOR_PATH,
        std::vector<std::string>{"--peis-name", "cfg", "--recover-hold-ms", "200",
                                 "--switch-margin", "0.2"},
        env);
    cfg = kernel->waitForPeer("cfg", 60s).value_or(0);
    dearId = kernel->waitForPeer("pb", 60s).value_or(0);
    thermostatId = kernel->waitForPeer("thermostat", 60s).value_or(0);
    if (!cfg || !dearId || !thermostatId) throw std::runtime_error("the ecology did not form");
    kernel->subscribe(peis::Pattern("config.event.*", cfg));
    kernel->subscribe(peis::Pattern("mi-temperature", thermostatId));
    kernel->set("config.goal.bench",
                "position@bench.mi-position\ntemperature@thermostat.mi-temperature\n");
  }

  bool reachable(peis::PeisId id) const {
    for (const auto& p : kernel->peers())
      if (p.id == id) return true;
    return false;
  }

  std::optional<peis::PeisId> pointedAt() const {
    auto ref = kernel->resolveMeta(kernel->id(), "mi-position");
    if (!ref) return std::nullopt;
    return ref->owner;
  }

  bool freshFrom(peis::PeisId producer, Clock::time_point after) {
    std::lock_guard lock(mu);
    for (const auto& [owner, at] : arrivals)
      if (owner == producer && at > after) return true;
    return false;
  }

  std::optional<Clock::time_point> firstFrom(peis::PeisId producer, Clock::time_point after) {
    std::lock_guard lock(mu);
    for (const auto& [owner, at] : arrivals)
      if (owner == producer && at > after) return at;
    return std::nullopt;
  }

  // Event tuples after number `from`: number -> (time in µs, data).
  std::map<std::uint64_t, std::pair<std::int64_t, std::string>> eventsAfter(std::uint64_t from) {
    std::map<std::uint64_t, std::pair<std::int64_t, std::string>> found;
    for (const auto& t : kernel->find(peis::Pattern("config.event.*", cfg))) {
      const auto n = peis::meta::eventNumber(t.key);
      if (n && *n > from) found[*n] = {t.ts_user.time_since_epoch().count(), t.data};
    }
    return found;
  }
  // On a missed trial: what the configurator did (stderr, for the reader).
  void explain(const std::string& what, std::uint64_t from) {
    std::cerr << "peis-bench-configurator: " << what << "; the configurator's events since:\n";
    for (const auto& [n, e] : eventsAfter(from > 30 ? from - 30 : 0))
      std::cerr << "  " << n << " " << e.second << "\n";
  }

  std::uint64_t lastEvent() {
    std::uint64_t last = 0;
    for (const auto& t : kernel->find(peis::Pattern("config.event.*", cfg)))
      if (auto n = peis::meta::eventNumber(t.key)) last = std::max(last, *n);
    return last;
  }
};

double msIn(const std::string& text) {
  static const std::regex inMs(R"( in ([0-9.]+) ms)");
  std::smatch m;
  return std::regex_search(text, m, inMs) ? std::stod(m[1]) : -1;
}

int repairBench(int trials, std::chrono::milliseconds liveness, bool freeze) {
  RepairSetup setup(liveness, freeze ? "freeze" : "kill");
  std::vector<double> detection, planning, deployment, total, fresh;
  int missed = 0, repointed = 0;
  std::uint64_t healthySeqno = 0;
  const std::string descriptor =
      std::string(PEIS_SOURCE_DIR) + "/tests/meta/descriptors/position-cheap.yaml";
  std::optional<peis::PeisId> previous;
  for (int t = 0; t < trials; ++t) {
    // The last trial's producer must be gone before another of its name starts.
    if (previous) waitUntil([&] { return !setup.reachable(*previous); }, 30s);
    auto cheap = std::make_unique<Program>(
        PEIS_SYNTHETIC_PATH,
        std::vector<std::string>{"--peis-name", "pa", "--descriptor", descriptor, "--period-ms",
                                 "20", "--freshness-ms", "200"},
        setup.env);
    const auto cheapId = setup.kernel->waitForPeer("pa", 60s);
    previous = cheapId;
    // The configurator puts the consumer (back) on the cheap producer.
    const auto since = Clock::now();
    if (!cheapId ||
        !waitUntil([&] { return setup.pointedAt() == cheapId && setup.freshFrom(*cheapId, since); },
                   60s)) {
      ++missed;
      continue;
    }
    const auto healthy = setup.kernel->get(setup.thermostatId, "mi-temperature");
    if (t == 0 && healthy) healthySeqno = healthy->seqno;
    const auto before = setup.lastEvent();
    const auto killedAt = Clock::now();
    const auto killedAtUs = peis::systemNow().time_since_epoch().count();
    cheap->stop(freeze ? SIGSTOP : SIGKILL);
    const bool repaired = waitUntil(
        [&] {
          bool deployed = false;
          for (const auto& [n, e] : setup.eventsAfter(before))
            deployed = deployed || e.second.rfind("deployed", 0) == 0;
          return deployed && setup.pointedAt() == setup.dearId &&
                 setup.freshFrom(setup.dearId, killedAt);
        },
        60s);
    if (freeze) cheap->stop(SIGKILL);
    if (!repaired) {
      setup.explain("trial " + std::to_string(t) + ": not repaired", before);
      ++missed;
      continue;
    }
    std::int64_t failureUs = 0, replannedUs = 0, deployedUs = 0;
    for (const auto& [n, e] : setup.eventsAfter(before)) {
      const auto& [us, data] = e;
      if (!failureUs && data.rfind("failure", 0) == 0) failureUs = us;
      if (failureUs && !replannedUs && data.rfind("replanned", 0) == 0) {
        replannedUs = us;
        planning.push_back(msIn(data));
      }
      if (replannedUs && !deployedUs && data.rfind("deployed", 0) == 0) {
        deployedUs = us;
        deployment.push_back(msIn(data));
      }
    }
    detection.push_back(static_cast<double>(failureUs - killedAtUs) / 1000.0);
    total.push_back(static_cast<double>(deployedUs - killedAtUs) / 1000.0);
    if (auto at = setup.firstFrom(setup.dearId, killedAt))
      fresh.push_back(std::chrono::duration<double, std::milli>(*at - killedAt).count());
    const auto after = setup.kernel->get(setup.thermostatId, "mi-temperature");
    if (!after || after->seqno != healthySeqno) ++repointed;
  }
  std::cout << "| " << (freeze ? "SIGSTOP (hung)" : "kill -9") << " | " << liveness.count() << " | "
            << detection.size() << " | " << row(detection, " / ") << " | " << row(planning, " / ")
            << " | " << row(deployment, " / ") << " | " << row(total, " / ") << " | "
            << row(fresh, " / ") << " | " << repointed << " | " << missed << " |\n";
  return 0;
}

int soakBench(int trials, std::chrono::milliseconds liveness) {
  RepairSetup setup(liveness, "soak");
  // Both cores busy for the whole soak.
  std::atomic<bool> busy{true};
  std::vector<std::thread> load;
  for (unsigned i = 0; i < std::max(2u, std::thread::hardware_concurrency()); ++i)
    load.emplace_back([&busy] {
      volatile std::uint64_t x = 0;
      while (busy.load(std::memory_order_relaxed)) x = x + 1;
    });
  const std::string descriptor =
      std::string(PEIS_SOURCE_DIR) + "/tests/meta/descriptors/position-cheap.yaml";
  Program cheap(PEIS_SYNTHETIC_PATH,
                {"--peis-name", "pa", "--descriptor", descriptor, "--period-ms", "20",
                 "--freshness-ms", "200"},
                setup.env);
  const auto cheapId = setup.kernel->waitForPeer("pa", 60s);
  const auto since = Clock::now();
  int falseRepairs = 0, stale = 0;
  const bool ready =
      cheapId &&
      waitUntil([&] { return setup.pointedAt() == cheapId && setup.freshFrom(*cheapId, since); },
                60s);
  const auto before = setup.lastEvent();
  if (ready) {
    for (int t = 0; t < trials; ++t) {
      const auto frozenAt = Clock::now();
      cheap.signal(SIGSTOP);
      std::this_thread::sleep_until(frozenAt + liveness * 6 / 10);  // the fault: frozen this long
      cheap.signal(SIGCONT);
      const auto thawed = Clock::now();
      waitUntil([&] { return setup.freshFrom(*cheapId, thawed); }, 10s);
      if (!setup.consumer->inputFresh("position")) ++stale;
      // A quiet period between freezes, as long as a repair would take to show.
      std::this_thread::sleep_until(thawed + liveness);
    }
    for (const auto& [n, e] : setup.eventsAfter(before))
      if (e.second.rfind("failure", 0) == 0) ++falseRepairs;
  }
  busy = false;
  for (auto& th : load) th.join();
  std::cout << "| " << liveness.count() << " | " << (ready ? trials : 0) << " | "
            << liveness.count() * 6 / 10 << " | " << falseRepairs << " | "
            << (setup.pointedAt() == cheapId ? "yes" : "no") << " |\n";
  return ready ? 0 : 1;
}

int usage() {
  std::cerr << "usage: peis-bench-configurator deploy|repair|soak [--trials N] [--liveness-ms MS] "
               "[--freeze] [--header]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const std::string what = argv[1];
  int trials = what == "deploy" ? 30 : 100;
  long livenessMs = 2000;
  bool freeze = false, header = false;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--trials" && i + 1 < argc) {
      trials = std::atoi(argv[++i]);
    } else if (a == "--liveness-ms" && i + 1 < argc) {
      livenessMs = std::atol(argv[++i]);
    } else if (a == "--freeze") {
      freeze = true;
    } else if (a == "--header") {
      header = true;
    } else {
      return usage();
    }
  }
  if (trials < 1 || livenessMs < 100) return usage();
  try {
    if (what == "deploy") return deployBench(trials);
    if (what == "repair") {
      if (header)
        std::cout << "| fault | liveness (ms) | trials | detection p50 / p99 / max (ms) | "
                     "planning p50 / p99 / max (ms) | deployment p50 / p99 / max (ms) | kill to "
                     "deployed p50 / p99 / max (ms) | fresh data at the consumer p50 / p99 / max "
                     "(ms) | healthy links re-pointed | trials missed |\n"
                     "|---|---|---|---|---|---|---|---|---|---|\n";
      return repairBench(trials, std::chrono::milliseconds(livenessMs), freeze);
    }
    if (what == "soak") {
      if (header)
        std::cout << "| liveness (ms) | freezes | frozen for (ms) | false repairs | still on the "
                     "first producer |\n|---|---|---|---|---|\n";
      return soakBench(trials, std::chrono::milliseconds(livenessMs));
    }
  } catch (const std::exception& e) {
    std::cerr << "peis-bench-configurator: " << e.what() << "\n";
    return 1;
  }
  return usage();
}
