// Component: status, inputs through meta tuples, actuators and descriptors.
// Every test waits for what it checks with a deadline instead of sleeping.
#include "peis/component.h"

#include <atomic>
#include <catch2/catch.hpp>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "peis/descriptor.h"
#include "peis/error.h"
#include "peis/kernel.h"
#include "support/error_matchers.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using peis::ComponentStatus;
using peis::ErrorCode;
using peis::test::waitFor;

namespace {

constexpr peis::PeisId kId = 77;

peis::Options testOptions() {
  peis::Options o;
  o.id = kId;
  o.name = "component-host";
  o.network = false;  // a kernel on its own: no sockets, no discovery
  o.discovery = false;
  return o;
}

using peis::test::HasCode;

std::string dataOf(const peis::Kernel& k, const std::string& key) {
  auto tuple = k.get(key);
  return tuple ? tuple->data : "<absent>";
}

bool waitForData(const peis::Kernel& k, const std::string& key, const std::string& value,
                 std::chrono::milliseconds deadline = 10s) {
  return waitFor([&] { return dataOf(k, key) == value; }, deadline);
}

// Runs on the kernel thread after everything queued so far; returns once it ran.
bool fence(peis::Kernel& k) {
  auto done = std::make_shared<std::atomic<bool>>(false);
  k.post([done] { *done = true; });
  return waitFor([&] { return done->load(); });
}

// Every value the status tuple takes, so that short-lived states are not missed.
class StatusLog {
 public:
  explicit StatusLog(peis::Kernel& k) : k_(k) {
    handle_ = k.onChange(peis::Pattern::exact(k.id(), "status"), [this](const peis::Tuple& t) {
      std::lock_guard lock(mu_);
      values_.push_back(t.data);
    });
  }
  ~StatusLog() {
    k_.removeCallback(handle_);
    fence(k_);  // a delivery already in progress has finished with `this`
  }
  // Index of the next value to look at.
  std::size_t mark() const {
    std::lock_guard lock(mu_);
    return values_.size();
  }
  // Waits until the status takes `value` at index `from` or later.
  bool waitFor(const std::string& value, std::size_t from) const {
    return peis::test::waitFor([&] {
      std::lock_guard lock(mu_);
      for (std::size_t i = from; i < values_.size(); ++i) {
        if (values_[i] == value) return true;
      }
      return false;
    });
  }

 private:
  peis::Kernel& k_;
  peis::CallbackHandle handle_ = 0;
  mutable std::mutex mu_;
  std::vector<std::string> values_;
};

}  // namespace

TEST_CASE("Component status names", "[unit][component]") {
  CHECK(std::string(peis::toString(ComponentStatus::Initializing)) == "initializing");
  CHECK(std::string(peis::toString(ComponentStatus::Waiting)) == "waiting");
  CHECK(std::string(peis::toString(ComponentStatus::Running)) == "running");
  CHECK(std::string(peis::toString(ComponentStatus::Error)) == "error");
}

TEST_CASE("Component publishes initializing and its name at construction", "[unit][component]") {
  peis::Kernel k(testOptions());
  peis::Component c(k, "camera");
  CHECK(c.name() == "camera");
  CHECK(&c.kernel() == &k);
  CHECK(c.status() == ComponentStatus::Initializing);
  CHECK(dataOf(k, "status") == "initializing");
  CHECK(dataOf(k, "component.name") == "camera");
  REQUIRE(k.get("cause.names").has_value());
  CHECK(k.get("cause.names")->data.empty());
  CHECK(c.missingInputs().empty());
}

TEST_CASE("Component with no inputs runs after start()", "[unit][component]") {
  peis::Kernel k(testOptions());
  peis::Component c(k, "clock");
  c.start();
  CHECK(c.status() == ComponentStatus::Running);
  CHECK(waitForData(k, "status", "running"));
  CHECK(dataOf(k, "cause.names").empty());
}

TEST_CASE("Component waits for its inputs", "[unit][component]") {
  std::mutex mu;
  std::vector<std::string> received;
  std::atomic<bool> onKernelThread{false};
  peis::Kernel k(testOptions());
  peis::Component c(k, "follower");

  SECTION("one input") {
    c.input("pos", {}, [&](const peis::Tuple& t) {
      onKernelThread = k.onKernelThread();
      std::lock_guard lock(mu);
      received.push_back(t.data);
    });
    // The input's meta tuple exists and points nowhere.
    REQUIRE(k.get("mi-pos").has_value());
    CHECK(k.get("mi-pos")->mimetype == peis::kMetaMimetype);
    CHECK(k.get("mi-pos")->data.empty());
    CHECK(c.status() == ComponentStatus::Initializing);
    CHECK(dataOf(k, "status") == "initializing");

    c.start();
    CHECK(waitForData(k, "status", "waiting"));
    CHECK(dataOf(k, "cause.names") == "pos");
    CHECK(c.status() == ComponentStatus::Waiting);
    CHECK(c.missingInputs() == std::vector<std::string>{"pos"});
    CHECK_FALSE(c.inputValue("pos").has_value());
    CHECK_FALSE(c.inputFresh("pos"));

    k.set("tracker.pos", "1.0 2.0");
    k.setMeta("mi-pos", k.id(), "tracker.pos");
    REQUIRE(waitForData(k, "status", "running"));
    CHECK(dataOf(k, "cause.names").empty());
    CHECK(c.status() == ComponentStatus::Running);
    CHECK(c.missingInputs().empty());
    REQUIRE(c.inputValue("pos").has_value());
    CHECK(c.inputValue("pos")->data == "1.0 2.0");
    CHECK(c.inputValue("pos")->key == "tracker.pos");
    CHECK(c.inputFresh("pos"));
    REQUIRE(waitFor([&] {
      std::lock_guard lock(mu);
      return !received.empty();
    }));
    CHECK(onKernelThread);

    k.set("tracker.pos", "3.0 4.0");
    CHECK(waitFor([&] {
      auto value = c.inputValue("pos");
      return value && value->data == "3.0 4.0";
    }));
    REQUIRE(waitFor([&] {
      std::lock_guard lock(mu);
      return received.size() == 2;
    }));
    std::lock_guard lock(mu);
    CHECK(received == std::vector<std::string>{"1.0 2.0", "3.0 4.0"});
  }

  SECTION("two inputs are listed space-separated") {
    c.input("pos");
    c.input("map");
    c.start();
    REQUIRE(waitForData(k, "status", "waiting"));
    CHECK(dataOf(k, "cause.names") == "map pos");
    CHECK(c.missingInputs() == std::vector<std::string>{"map", "pos"});

    k.set("mapper.map", "grid");
    k.setMeta("mi-map", k.id(), "mapper.map");
    REQUIRE(waitForData(k, "cause.names", "pos"));
    CHECK(dataOf(k, "status") == "waiting");

    k.set("tracker.pos", "0 0");
    k.setMeta("mi-pos", k.id(), "tracker.pos");
    CHECK(waitForData(k, "status", "running"));
    CHECK(dataOf(k, "cause.names").empty());
  }

  SECTION("the meta tuple points at a tuple before the input is declared") {
    k.set("tracker.pos", "5 5");
    k.setMeta("mi-pos", k.id(), "tracker.pos");
    c.input("pos");
    c.start();
    CHECK(waitForData(k, "status", "running"));
    REQUIRE(c.inputValue("pos").has_value());
    CHECK(c.inputValue("pos")->data == "5 5");
  }

  SECTION("an unknown input has no value") {
    CHECK_THROWS_MATCHES(c.inputValue("nope"), peis::Error, HasCode(ErrorCode::NotFound));
    CHECK_FALSE(c.inputFresh("nope"));
  }
}

TEST_CASE("Component input goes stale without fresh values", "[unit][component]") {
  std::atomic<bool> producing{true};
  std::atomic<long> written{0};
  peis::Kernel k(testOptions());
  StatusLog log(k);
  peis::Component c(k, "stale");
  c.input("pos", 100ms);
  c.start();
  REQUIRE(waitForData(k, "status", "waiting"));

  // A producer on the kernel thread that writes every 10 ms while producing.
  const auto producer = k.every(10ms, [&] {
    if (producing) k.set("tracker.pos", std::to_string(++written));
  });
  auto mark = log.mark();
  k.setMeta("mi-pos", k.id(), "tracker.pos");
  REQUIRE(log.waitFor("running", mark));
  CHECK(waitForData(k, "status", "running"));

  // The producer stops: the value grows older than 100 ms.
  mark = log.mark();
  producing = false;
  REQUIRE(log.waitFor("waiting", mark));
  CHECK(waitForData(k, "status", "waiting", 5s));
  CHECK(dataOf(k, "cause.names") == "pos");
  CHECK_FALSE(c.inputFresh("pos"));
  CHECK(c.inputValue("pos").has_value());  // still held, only stale
  CHECK(c.status() == ComponentStatus::Waiting);

  // It writes again: running again.
  mark = log.mark();
  producing = true;
  CHECK(log.waitFor("running", mark));
  CHECK(waitForData(k, "status", "running"));
  k.cancelTimer(producer);
  REQUIRE(fence(k));
}

TEST_CASE("Component re-pointed to a target with no value waits", "[unit][component]") {
  peis::Kernel k(testOptions());
  StatusLog log(k);
  peis::Component c(k, "follower");
  c.input("pos");
  c.start();
  k.set("tracker.pos", "1 1");
  k.setMeta("mi-pos", k.id(), "tracker.pos");
  REQUIRE(waitForData(k, "status", "running"));

  auto mark = log.mark();
  k.setMeta("mi-pos", k.id(), "other.pos");
  REQUIRE(log.waitFor("waiting", mark));
  CHECK(waitForData(k, "status", "waiting"));
  CHECK(dataOf(k, "cause.names") == "pos");
  CHECK_FALSE(c.inputValue("pos").has_value());

  // The new producer starts writing.
  mark = log.mark();
  k.set("other.pos", "2 2");
  REQUIRE(log.waitFor("running", mark));
  CHECK(waitForData(k, "status", "running"));
  REQUIRE(c.inputValue("pos").has_value());
  CHECK(c.inputValue("pos")->key == "other.pos");
  CHECK(c.inputValue("pos")->data == "2 2");

  // The old one no longer counts.
  k.set("tracker.pos", "9 9");
  REQUIRE(fence(k));
  CHECK(c.inputValue("pos")->data == "2 2");
}

TEST_CASE("Component fail() reports an error until start()", "[unit][component]") {
  peis::Kernel k(testOptions());
  peis::Component c(k, "camera");
  c.start();
  REQUIRE(waitForData(k, "status", "running"));

  c.fail("camera lost");
  CHECK(waitForData(k, "status", "error"));
  CHECK(dataOf(k, "cause.names") == "camera lost");
  CHECK(c.status() == ComponentStatus::Error);

  c.start();
  CHECK(waitForData(k, "status", "running"));
  CHECK(dataOf(k, "cause.names").empty());
  CHECK(c.status() == ComponentStatus::Running);

  SECTION("an error wins over missing inputs") {
    c.input("frame");
    REQUIRE(waitForData(k, "status", "waiting"));
    c.fail("driver crashed");
    CHECK(waitForData(k, "status", "error"));
    CHECK(dataOf(k, "cause.names") == "driver crashed");
    c.start();
    CHECK(waitForData(k, "status", "waiting"));
    CHECK(dataOf(k, "cause.names") == "frame");
  }
}

TEST_CASE("Component actuator applies requested states", "[unit][component]") {
  std::mutex mu;
  std::vector<std::string> requests;
  std::atomic<bool> onKernelThread{false};
  peis::Kernel k(testOptions());
  peis::Component c(k, "lamp");
  c.actuator(
      "light",
      [&](const std::string& requested) {
        onKernelThread = k.onKernelThread();
        std::lock_guard lock(mu);
        requests.push_back(requested);
        if (requested == "broken") throw std::runtime_error("bulb blown");
        return requested == "on" ? std::string("on (100%)") : requested;
      },
      "off");
  CHECK(dataOf(k, "light.currState") == "off");
  CHECK(dataOf(k, "light.status") == "ok");

  k.set("light.reqState", "on");
  REQUIRE(waitForData(k, "light.currState", "on (100%)"));
  CHECK(waitForData(k, "light.status", "ok"));
  CHECK(onKernelThread);
  {
    std::lock_guard lock(mu);
    CHECK(requests == std::vector<std::string>{"on"});
  }

  k.set("light.reqState", "broken");
  REQUIRE(waitFor([&] { return dataOf(k, "light.status").rfind("error: ", 0) == 0; }));
  CHECK(dataOf(k, "light.status") == "error: bulb blown");
  CHECK(dataOf(k, "light.currState") == "on (100%)");
  CHECK(k.callbackErrors() == 0);

  k.set("light.reqState", "off");
  CHECK(waitForData(k, "light.currState", "off"));
  CHECK(waitForData(k, "light.status", "ok"));

  c.setActuatorState("light", "dimmed", "ok");
  CHECK(dataOf(k, "light.currState") == "dimmed");
  CHECK(dataOf(k, "light.status") == "ok");
}

TEST_CASE("Component applies a request made before the actuator exists", "[unit][component]") {
  std::atomic<int> applied{0};
  std::mutex mu;
  std::string lastRequest;

  SECTION("set with --peis-set-tuple") {
    auto o = testOptions();
    o.setTuples = {{"light.reqState", "on"}};
    peis::Kernel k(o);
    peis::Component c(k, "lamp");
    c.actuator("light", [&](const std::string& requested) {
      std::lock_guard lock(mu);
      lastRequest = requested;
      ++applied;
      return requested;
    });
    REQUIRE(waitForData(k, "light.currState", "on"));
    CHECK(waitForData(k, "light.status", "ok"));
    CHECK(applied == 1);
    std::lock_guard lock(mu);
    CHECK(lastRequest == "on");
  }

  SECTION("set through the kernel") {
    peis::Kernel k(testOptions());
    k.set("light.reqState", "dim");
    peis::Component c(k, "lamp");
    c.actuator("light", [&](const std::string& requested) {
      ++applied;
      return requested + "med";
    });
    CHECK(waitForData(k, "light.currState", "dimmed"));
    CHECK(applied == 1);
  }
}

TEST_CASE("Component rejects an input or actuator declared twice", "[unit][component]") {
  peis::Kernel k(testOptions());
  peis::Component c(k, "twice");
  c.input("pos");
  CHECK_THROWS_MATCHES(c.input("pos"), peis::Error, HasCode(ErrorCode::InvalidArgument));
  CHECK_THROWS_MATCHES(c.input("pos", 100ms), peis::Error, HasCode(ErrorCode::InvalidArgument));
  c.actuator("light", [](const std::string& s) { return s; });
  CHECK_THROWS_MATCHES(c.actuator("light", [](const std::string& s) { return s; }), peis::Error,
                       HasCode(ErrorCode::InvalidArgument));
  CHECK_THROWS_MATCHES(c.input("bad name"), peis::Error, HasCode(ErrorCode::InvalidKey));
  CHECK_THROWS_MATCHES(c.actuator("bad*", [](const std::string& s) { return s; }), peis::Error,
                       HasCode(ErrorCode::InvalidKey));
  c.start();
  CHECK(waitForData(k, "status", "waiting"));
  CHECK(dataOf(k, "cause.names") == "pos");
}

TEST_CASE("Component publishes its descriptor", "[unit][component]") {
  const auto descriptor = peis::Descriptor::fromYaml(R"(
component: mover
functionalities:
  - name: goto
    description: drive to a pose
    inputs:
      - {name: target, type: pose2d}
      - {name: map, type: occupancy}
    outputs:
      - {name: pose, type: pose2d}
    preconditions: [localized, battery-ok]
    cost: 2.5
  - name: stop
)",
                                                     "mover.yaml");
  peis::Kernel k(testOptions());
  peis::Component c(k, "mover", descriptor);
  CHECK(dataOf(k, "status") == "initializing");
  CHECK(dataOf(k, "component.name") == "mover");
  CHECK(dataOf(k, "functionalities") == "goto stop");

  CHECK(dataOf(k, "functionality.goto.inputs") == "target:pose2d map:occupancy");
  CHECK(dataOf(k, "functionality.goto.outputs") == "pose:pose2d");
  CHECK(dataOf(k, "functionality.goto.preconditions") == "localized battery-ok");
  CHECK(std::stod(dataOf(k, "functionality.goto.cost")) == Approx(2.5));
  CHECK(dataOf(k, "functionality.goto.description") == "drive to a pose");

  CHECK(dataOf(k, "functionality.stop.inputs").empty());
  CHECK(dataOf(k, "functionality.stop.outputs").empty());
  CHECK(dataOf(k, "functionality.stop.preconditions").empty());
  CHECK(std::stod(dataOf(k, "functionality.stop.cost")) == Approx(1.0));
  CHECK_FALSE(k.get("functionality.stop.description").has_value());

  const auto published = k.get("component.descriptor");
  REQUIRE(published.has_value());
  CHECK(published->mimetype == "application/yaml");
  const auto back = peis::Descriptor::fromYaml(published->data, "component.descriptor");
  CHECK(back.component == descriptor.component);
  CHECK(back.functionalities == descriptor.functionalities);
}

TEST_CASE("Component rejects an invalid name", "[unit][component]") {
  peis::Kernel k(testOptions());
  CHECK_THROWS_MATCHES(peis::Component(k, "bad name"), peis::Error,
                       HasCode(ErrorCode::InvalidName));
  CHECK_THROWS_MATCHES(peis::Component(k, "a.b"), peis::Error, HasCode(ErrorCode::InvalidName));
  CHECK_THROWS_MATCHES(peis::Component(k, ""), peis::Error, HasCode(ErrorCode::InvalidName));
  CHECK_THROWS_MATCHES(peis::Component(k, "1234"), peis::Error, HasCode(ErrorCode::InvalidName));
  CHECK_FALSE(k.get("component.name").has_value());
  CHECK_FALSE(k.get("status").has_value());
}

TEST_CASE("Destroying a Component removes its callbacks", "[unit][component]") {
  std::atomic<int> applied{0}, inputValues{0}, markerCalls{0};
  peis::Kernel k(testOptions());
  {
    peis::Component c(k, "lamp");
    c.actuator("light", [&](const std::string& requested) {
      ++applied;
      return requested;
    });
    c.input("pos", 100ms, [&](const peis::Tuple&) { ++inputValues; });
    c.start();
    k.set("light.reqState", "on");
    REQUIRE(waitForData(k, "light.currState", "on"));
    CHECK(applied == 1);
    k.set("tracker.pos", "1");
    k.setMeta("mi-pos", k.id(), "tracker.pos");
    REQUIRE(waitFor([&] { return inputValues == 1; }));
  }
  // A marker callback registered now runs after any callback the component
  // would still have on the same event.
  k.onChange(peis::Pattern::exact(k.id(), "light.reqState"),
             [&](const peis::Tuple&) { ++markerCalls; });
  k.set("light.reqState", "off");
  k.set("tracker.pos", "2");
  REQUIRE(waitForData(k, "light.reqState", "off"));
  REQUIRE(waitFor([&] { return markerCalls == 1; }));
  REQUIRE(fence(k));
  CHECK(applied == 1);
  CHECK(inputValues == 1);
  CHECK(dataOf(k, "light.currState") == "on");
}

TEST_CASE("Component onStatusChange: an actuator goes safe when its input goes stale",
          "[unit][component]") {
  std::atomic<bool> producing{true};
  std::atomic<bool> onKernelThread{true};
  std::mutex mu;
  std::vector<std::string> changes;  // "status:causes", in order
  peis::Kernel k(testOptions());
  peis::Component motor(k, "motor");
  motor.input("command", 100ms);
  motor.actuator(
      "drive", [](const std::string& wanted) { return wanted; }, "stopped");
  motor.onStatusChange([&](ComponentStatus status, const std::string& causes) {
    onKernelThread = onKernelThread && k.onKernelThread();
    {
      std::lock_guard lock(mu);
      changes.push_back(std::string(peis::toString(status)) + ":" + causes);
    }
    // The safe state: stop the drive as soon as the command is stale.
    if (status != ComponentStatus::Running) k.set("drive.reqState", "stopped");
  });
  auto saw = [&](const std::string& change) {
    return waitFor([&] {
      std::lock_guard lock(mu);
      return std::find(changes.begin(), changes.end(), change) != changes.end();
    });
  };
  motor.start();
  REQUIRE(saw("waiting:command"));

  const auto producer = k.every(10ms, [&] {
    if (producing) k.set("planner.command", "forward");
  });
  k.setMeta("mi-command", k.id(), "planner.command");
  REQUIRE(saw("running:"));
  k.set("drive.reqState", "forward");
  REQUIRE(waitForData(k, "drive.currState", "forward"));

  producing = false;  // the command goes stale: the callback stops the drive
  REQUIRE(saw("waiting:command"));
  CHECK(waitForData(k, "drive.currState", "stopped"));
  CHECK(onKernelThread);
  {
    std::lock_guard lock(mu);
    CHECK(changes.front() == "waiting:command");  // initializing came before the callback
  }
  k.cancelTimer(producer);
  REQUIRE(fence(k));
}

TEST_CASE("Component onStatusChange reports fail() and can be removed", "[unit][component]") {
  std::atomic<int> calls{0};
  std::string last;
  std::mutex mu;
  peis::Kernel k(testOptions());
  peis::Component c(k, "worker");
  c.onStatusChange([&](ComponentStatus status, const std::string& causes) {
    std::lock_guard lock(mu);
    last = std::string(peis::toString(status)) + ":" + causes;
    ++calls;
  });
  c.start();
  c.fail("camera unplugged");
  REQUIRE(waitFor([&] { return calls.load() == 2; }));
  {
    std::lock_guard lock(mu);
    CHECK(last == "error:camera unplugged");
  }
  c.onStatusChange({});
  c.start();
  REQUIRE(waitForData(k, "status", "running"));
  REQUIRE(fence(k));
  CHECK(calls == 2);
}

TEST_CASE("Component outputs: declared, listed, written with their options", "[unit][component]") {
  peis::Kernel k(testOptions());
  peis::Component tracker(k, "tracker");
  peis::WriteOptions json;
  json.mimetype = "application/json";
  tracker.output("position", json);
  tracker.output("confidence");
  CHECK(tracker.outputs() == std::vector<std::string>{"confidence", "position"});
  CHECK(dataOf(k, "component.outputs") == "confidence position");
  CHECK_FALSE(k.get("position").has_value());  // declaring writes no value

  const auto written = tracker.write("position", "{\"x\":1}");
  CHECK(written.key == "position");
  CHECK(dataOf(k, "position") == "{\"x\":1}");
  CHECK(k.get("position")->mimetype == "application/json");
  tracker.write("confidence", "0.9");
  CHECK(k.get("confidence")->mimetype == "text/plain");

  REQUIRE_THROWS_MATCHES(tracker.write("postion", "x"), peis::Error, HasCode(ErrorCode::NotFound));
  CHECK_FALSE(k.get("postion").has_value());
  REQUIRE_THROWS_MATCHES(tracker.output("position"), peis::Error,
                         HasCode(ErrorCode::InvalidArgument));
  REQUIRE_THROWS_MATCHES(tracker.output("bad..key"), peis::Error, HasCode(ErrorCode::InvalidKey));
}

TEST_CASE("Component output with a ttl expires when the component stops writing",
          "[unit][component]") {
  peis::Kernel k(testOptions());
  peis::Component sensor(k, "sensor");
  peis::WriteOptions shortLived;
  shortLived.ttl = 100ms;
  sensor.output("reading", shortLived);
  sensor.write("reading", "42");
  CHECK(k.get("reading")->ts_expire != peis::kNoTime);
  CHECK(waitFor([&] { return !k.get("reading").has_value(); }));
}
