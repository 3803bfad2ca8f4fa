// peis-demo: the most complete demonstration of what the platform does
// today, run by `./run demo`. One PEIS hosts a lamp component; two simulated
// light sensors publish into its tuple space; a configurator step points the
// lamp's input (meta tuple mi-brightness) at one sensor, the sensor fails,
// the lamp notices the stale input, and the configurator re-points it at the
// other sensor. Every line of the timeline comes from a real callback.
// Exits 0 when the lamp ended where the goal says, 1 otherwise.
#include <peis/peis.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>

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

class Timeline {
 public:
  void say(const std::string& who, const std::string& what) {
    std::lock_guard lock(mu_);
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start_);
    std::printf("%+7.3fs  %-12s %s\n", static_cast<double>(ms.count()) / 1000.0, who.c_str(),
                what.c_str());
    std::fflush(stdout);
  }

 private:
  std::mutex mu_;
  Clock::time_point start_ = Clock::now();
};

// Waits for `condition` or gives up with a clear message.
bool step(Timeline& timeline, const std::string& goal, const std::function<bool()>& condition,
          std::chrono::milliseconds deadline = 5s) {
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

}  // namespace

int main(int argc, char** argv) {
  peis::Options options;
  try {
    options = peis::Options::fromArgs(argc, argv);
  } catch (const peis::Error& e) {
    std::cerr << "peis-demo: " << e.what() << "\n";
    return 2;
  }
  if (options.help || argc > 1) {
    std::cout << "Usage: peis-demo [options]\n\n"
                 "Runs a lamp component whose brightness input is configured, fails over\n"
                 "and is re-configured through meta tuples, and prints the timeline.\n"
                 "Exits 0 when the goal is met.\n\n"
              << peis::Options::helpText();
    return options.help ? 0 : 2;
  }
  if (!options.id) options.id = 6890;
  if (options.name.empty()) options.name = "demo-home";

  Timeline timeline;
  peis::Kernel kernel(options);
  timeline.say("kernel",
               "PEIS " + std::to_string(kernel.id()) + " '" + kernel.name() + "' up, publishing " +
                   std::to_string(kernel.find(peis::Pattern("kernel.*", kernel.id())).size()) +
                   " kernel.* tuples");

  // Everything the lamp component publishes goes on the timeline.
  kernel.onChange(peis::Pattern("status", kernel.id()), [&](const peis::Tuple& t) {
    const auto cause = valueOf(kernel, "cause.names");
    timeline.say("lamp",
                 "status = " + t.data + (cause.empty() ? "" : " (cause.names: " + cause + ")"));
  });
  kernel.onChange(peis::Pattern("light.currState", kernel.id()), [&](const peis::Tuple& t) {
    timeline.say("lamp",
                 "light.currState = " + t.data + " (seqno " + std::to_string(t.seqno) + ")");
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
      timeline.say("lamp", "brightness " + t.data + "% from " + std::to_string(t.owner) + "." +
                               t.key + ": too dark, requesting light on");
      kernel.set("light.reqState", "on");
    } else if (percent > 60 && current != "off") {
      timeline.say("lamp",
                   "brightness " + t.data + "% from " + t.key + ": bright, requesting light off");
      kernel.set("light.reqState", "off");
    }
  });
  lamp.start();

  // Two light sensors. Sensor A sees the evening fall; sensor B sees daylight.
  std::atomic<int> dusk{80};
  auto sensorA = kernel.every(40ms, [&] {
    dusk = std::max(10, dusk - 5);
    kernel.set("sensor-a.brightness", std::to_string(dusk.load()));
  });
  kernel.every(40ms, [&] { kernel.set("sensor-b.brightness", "85"); });

  // A photo request that nobody answers in time expires by itself.
  kernel.onDelete(peis::Pattern("photo.request", kernel.id()), [&](const peis::Tuple& t) {
    timeline.say("kernel", "photo.request '" + t.data + "' expired and was deleted");
  });

  bool ok = step(timeline, "lamp waiting for its input", [&] {
    return valueOf(kernel, "status") == "waiting" && valueOf(kernel, "cause.names") == "brightness";
  });
  if (ok) {
    timeline.say("config", "pointing the lamp's input at sensor A");
    kernel.setMeta(peis::metaInputKey("brightness"), kernel.id(), "sensor-a.brightness");
    ok = step(timeline, "lamp running on sensor A",
              [&] { return valueOf(kernel, "status") == "running"; });
  }
  if (ok) {
    ok = step(timeline, "light on at dusk",
              [&] { return valueOf(kernel, "light.currState") == "on"; });
  }
  if (ok) {
    timeline.say("sensor-a", "fails (stops publishing)");
    kernel.cancelTimer(sensorA);
    ok = step(timeline, "lamp noticing the stale input",
              [&] { return valueOf(kernel, "status") == "waiting"; });
  }
  if (ok) {
    timeline.say("config", "re-pointing the lamp's input at sensor B");
    kernel.setMeta(peis::metaInputKey("brightness"), kernel.id(), "sensor-b.brightness");
    ok = step(timeline, "lamp running on sensor B, light off", [&] {
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
    const auto functionalities = valueOf(kernel, "functionalities");
    timeline.say("lamp", "advertises functionality '" + functionalities + "' with inputs '" +
                             valueOf(kernel, "functionality.illuminate.inputs") + "'");
    timeline.say("demo", "goal met: setting kernel.do-quit = yes");
    kernel.set(peis::special::kDoQuit, "yes");
    ok = kernel.runFor(5s);
    if (!ok) timeline.say("demo", "FAILED: the kernel did not quit");
  }
  timeline.say("demo", ok ? "SUCCESS" : "FAILURE");
  return ok ? 0 : 1;
}
