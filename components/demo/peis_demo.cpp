// peis-demo: the first demonstration (`./run demo` runs the photo-sofa
// scenario now); kept as the test integration:demo-reaches-goal for what
// the scenario does not show. Three PEIS in separate processes talk over the
// real network stack (TCP on loopback, found by discovery): two light
// sensors, and a host PEIS running a lamp component whose input, meta tuple
// mi-brightness, a configurator points at sensor A. Sensor A's process is
// killed; the lamp reports its stale input, the configurator re-points the
// input at sensor B, the lamp follows. At the end sensor B is told to quit
// through its kernel.do-quit tuple. Every timeline line comes from a real
// callback. Exits 0 when the goal is met, 1 otherwise.
#include <peis/component.h>
#include <peis/peis.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const char* kLampDescriptor = R"(
component: lamp
functionalities:
  - name: illuminate
    description: turns the floor lamp on when the room is too dark
    inputs: [{name: brightness, type: percent}]
    outputs: [{name: light, type: on-off}]
    preconditions: [mains-power]
    cost: 1
)";

constexpr peis::PeisId kSensorA = 101;
constexpr peis::PeisId kSensorB = 102;

class Timeline {
 public:
  void say(const std::string& who, const std::string& what) {
    std::lock_guard lock(mu_);
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start_);
    std::printf("%+7.3fs  %-10s %s\n", static_cast<double>(ms.count()) / 1000.0, who.c_str(),
                what.c_str());
    std::fflush(stdout);
  }

 private:
  std::mutex mu_;
  Clock::time_point start_ = Clock::now();
};

// Waits for `condition` or gives up with a clear message.
bool step(Timeline& timeline, const std::string& goal, const std::function<bool()>& condition,
          std::chrono::milliseconds deadline = 10s) {
  const auto until = Clock::now() + deadline;
  while (!condition()) {
    if (Clock::now() >= until) {
      timeline.say("demo", "FAILED: " + goal + " did not happen within " +
                               std::to_string(deadline.count()) + " ms");
      return false;
    }
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

std::string valueOf(const peis::Kernel& kernel, const std::string& key) {
  auto tuple = kernel.get(key);
  return tuple ? tuple->data : std::string();
}

// A light sensor PEIS (child process): publishes `brightness` every 40 ms,
// falling from 80 % (dusk) or steady at 85 % (daylight).
int runSensor(peis::Options options, const std::string& profile) {
  peis::Kernel kernel(options);
  std::atomic<int> level{profile == "dusk" ? 80 : 85};
  kernel.every(40ms, [&] {
    if (profile == "dusk") level = std::max(10, level - 5);
    kernel.set("brightness", std::to_string(level.load()));
  });
  kernel.run();
  return 0;
}

struct Child {
  pid_t pid = -1;
  ~Child() {
    if (pid > 0) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  }
};

pid_t spawnSensor(const std::string& self, peis::PeisId id, const std::string& name,
                  const std::string& ecology, const std::string& profile) {
  const pid_t pid = fork();
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive the parent
    std::vector<std::string> args{
        self,        "--role",           "sensor",      "--profile", profile,
        "--peis-id", std::to_string(id), "--peis-name", name,        "--peis-ecology",
        ecology};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv("/proc/self/exe", argv.data());
    _exit(127);
  }
  return pid;
}

bool exitedWithin(pid_t pid, std::chrono::milliseconds deadline, int& status) {
  const auto until = Clock::now() + deadline;
  while (Clock::now() < until) {
    if (waitpid(pid, &status, WNOHANG) == pid) return true;
    std::this_thread::sleep_for(5ms);
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  peis::Options options;
  try {
    options = peis::Options::fromArgs(argc, argv);
  } catch (const peis::Error& e) {
    std::cerr << "peis-demo: " << e.what() << "\n";
    return 2;
  }
  if (argc == 5 && std::strcmp(argv[1], "--role") == 0 && std::strcmp(argv[3], "--profile") == 0) {
    return runSensor(options, argv[4]);
  }
  if (options.help || argc > 1) {
    std::cout << "Usage: peis-demo [options]\n\n"
                 "Starts two light-sensor PEIS and a lamp component in separate processes,\n"
                 "configures the lamp's input through a meta tuple, kills a sensor, re-points\n"
                 "the input, and prints the timeline. Exits 0 when the goal is met.\n\n"
              << peis::Options::helpText();
    return options.help ? 0 : 2;
  }
  if (!options.id) options.id = 6890;
  if (options.name.empty()) options.name = "home-pc";
  if (options.ecology == "default") options.ecology = "demo-" + std::to_string(getpid());

  Timeline timeline;
  peis::Kernel kernel(options);
  timeline.say("kernel", "PEIS " + std::to_string(kernel.id()) + " '" + kernel.name() +
                             "' up on TCP port " + std::to_string(kernel.port()) + ", ecology " +
                             options.ecology);

  // Joins and leaves, as the kernel.peers tuple shows them.
  kernel.onChange(peis::Pattern(peis::special::kPeers, kernel.id()), [&](const peis::Tuple& t) {
    timeline.say("ecology", "reachable PEIS: " + (t.data.empty() ? "(none)" : t.data));
  });
  // Everything the lamp component publishes goes on the timeline.
  kernel.onChange(peis::Pattern("status", kernel.id()), [&](const peis::Tuple& t) {
    const auto cause = valueOf(kernel, "cause.names");
    timeline.say("lamp",
                 "status = " + t.data + (cause.empty() ? "" : " (cause.names: " + cause + ")"));
  });
  kernel.onChange(peis::Pattern("light.currState", kernel.id()), [&](const peis::Tuple& t) {
    timeline.say("lamp", "light.currState = " + t.data);
  });
  kernel.onChange(peis::Pattern("mi-brightness", kernel.id()), [&](const peis::Tuple& t) {
    timeline.say("config", "mi-brightness -> " + (t.data.empty() ? "(nothing)" : t.data));
  });

  // The lamp: turns the light on below 40 % brightness, off above 60 %.
  peis::Component lamp(kernel, "lamp", peis::Descriptor::fromYaml(kLampDescriptor, "lamp.yaml"));
  lamp.actuator(
      "light", [&](const std::string& wanted) { return wanted; }, "off");
  lamp.input("brightness", 300ms, [&](const peis::Tuple& t) {
    const int percent = std::atoi(t.data.c_str());
    const auto current = valueOf(kernel, "light.currState");
    if (percent < 40 && current != "on") {
      timeline.say("lamp", t.fullName() + " = " + t.data + "%: too dark, light on");
      kernel.set("light.reqState", "on");
    } else if (percent > 60 && current != "off") {
      timeline.say("lamp", t.fullName() + " = " + t.data + "%: bright, light off");
      kernel.set("light.reqState", "off");
    }
  });
  lamp.start();

  // A photo request that nobody answers in time expires by itself.
  kernel.onDelete(peis::Pattern("photo.request", kernel.id()), [&](const peis::Tuple& t) {
    timeline.say("kernel", "photo.request '" + t.data + "' expired and was deleted");
  });

  const std::string self = argv[0];
  Child sensorA{spawnSensor(self, kSensorA, "sensor-a", options.ecology, "dusk")};
  Child sensorB{spawnSensor(self, kSensorB, "sensor-b", options.ecology, "daylight")};
  timeline.say("demo",
               "started sensor-a (PEIS 101, dusk) and sensor-b (PEIS 102, daylight) "
               "as separate processes");
  auto reachable = [&](peis::PeisId id) {
    for (const auto& peer : kernel.peers()) {
      if (peer.id == id) return true;
    }
    return false;
  };

  bool ok = step(timeline, "the lamp waiting for its input", [&] {
    return valueOf(kernel, "status") == "waiting" && valueOf(kernel, "cause.names") == "brightness";
  });
  ok = ok && step(timeline, "both sensors joining",
                  [&] { return reachable(kSensorA) && reachable(kSensorB); });
  if (ok) {
    timeline.say("config", "pointing the lamp's input at sensor-a's brightness");
    kernel.setMeta(peis::metaInputKey("brightness"), kSensorA, "brightness");
    ok = step(timeline, "lamp running on sensor-a",
              [&] { return valueOf(kernel, "status") == "running"; });
  }
  ok = ok && step(timeline, "light on at dusk",
                  [&] { return valueOf(kernel, "light.currState") == "on"; });
  if (ok) {
    timeline.say("demo", "kill -9 sensor-a (pid " + std::to_string(sensorA.pid) + ")");
    kill(sensorA.pid, SIGKILL);
    ok = step(timeline, "the lamp noticing its stale input",
              [&] { return valueOf(kernel, "status") == "waiting"; });
    ok = ok && step(timeline, "sensor-a leaving the ecology", [&] { return !reachable(kSensorA); });
  }
  if (ok) {
    timeline.say("config", "re-pointing the lamp's input at sensor-b's brightness");
    kernel.setMeta(peis::metaInputKey("brightness"), kSensorB, "brightness");
    ok = step(timeline, "lamp running on sensor-b, light off", [&] {
      return valueOf(kernel, "status") == "running" && valueOf(kernel, "light.currState") == "off";
    });
  }
  if (ok) {
    peis::WriteOptions ttl;
    ttl.ttl = 200ms;
    kernel.set("photo.request", "sofa", ttl);
    timeline.say("astrid", "posts photo.request 'sofa' with a 200 ms lifetime");
    ok = step(timeline, "photo.request expiry", [&] { return !kernel.get("photo.request"); });
  }
  if (ok) {
    for (const auto* line : {"dusk ", "failover ", "done"}) kernel.append("demo.log", line);
    const auto log = kernel.get("demo.log");
    timeline.say("kernel", "demo.log appended atomically: '" + log->data + "' (seqno " +
                               std::to_string(log->seqno) + ")");
    timeline.say("lamp", "advertises functionality '" + valueOf(kernel, "functionalities") +
                             "' with inputs '" +
                             valueOf(kernel, "functionality.illuminate.inputs") + "'");
    timeline.say("demo",
                 "setting 102.kernel.do-quit = yes (a remote write, accepted by its owner)");
    kernel.set(kSensorB, peis::special::kDoQuit, "yes");
    int status = 0;
    ok = exitedWithin(sensorB.pid, 10s, status) && WIFEXITED(status) && WEXITSTATUS(status) == 0;
    if (ok) {
      sensorB.pid = -1;
      timeline.say("sensor-b", "exited cleanly with status 0");
    } else {
      timeline.say("demo", "FAILED: sensor-b did not exit cleanly");
    }
  }
  if (ok) {
    timeline.say("demo", "goal met: setting kernel.do-quit = yes");
    kernel.set(peis::special::kDoQuit, "yes");
    ok = kernel.runFor(5s);
  }
  timeline.say("demo", ok ? "SUCCESS" : "FAILURE");
  return ok ? 0 : 1;
}
