// Kernel: the tuple space behind one kernel thread. Every test waits for what
// it checks with a deadline (peis::test::waitFor) instead of sleeping.
#include "peis/kernel.h"

#include <algorithm>
#include <atomic>
#include <catch2/catch.hpp>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "peis/error.h"
#include "peis/key.h"
#include "support/error_matchers.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using peis::ErrorCode;
using peis::test::waitFor;

namespace {

constexpr peis::PeisId kId = 42;

peis::Options testOptions(peis::PeisId id = kId, std::string name = "tester") {
  peis::Options o;
  o.id = id;
  o.name = std::move(name);
  // A unit test's kernel stands alone: no sockets, no discovery of the other
  // PEIS (or test processes) on this host.
  o.network = false;
  o.discovery = false;
  return o;
}

using peis::test::HasCode;

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> result;
  for (std::string word; in >> word;) result.push_back(word);
  return result;
}

bool contains(const std::vector<std::string>& items, const std::string& item) {
  return std::find(items.begin(), items.end(), item) != items.end();
}

std::string dataOf(const peis::Kernel& k, const std::string& key) {
  auto tuple = k.get(key);
  return tuple ? tuple->data : "<absent>";
}

// A thread that writes until told to stop; stopped and joined on scope exit
// (also when a REQUIRE fails). `step` is called in a loop.
class Writer {
 public:
  explicit Writer(std::function<void()> step)
      : thread_([this, step = std::move(step)] {
          while (!stop_) step();
        }) {}
  ~Writer() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Runs on the kernel thread after everything queued so far; returns once it ran.
bool fence(peis::Kernel& k) {
  auto done = std::make_shared<std::atomic<bool>>(false);
  k.post([done] { *done = true; });
  return waitFor([&] { return done->load(); });
}

}  // namespace

TEST_CASE("Kernel publishes the special tuples at start", "[unit][kernel]") {
  peis::Kernel k(testOptions());
  CHECK(k.id() == kId);
  CHECK(k.name() == "tester");
  for (const char* key :
       {peis::special::kName, peis::special::kId, peis::special::kHostname, peis::special::kUser,
        peis::special::kVersion, peis::special::kAllKeys, peis::special::kSubscribers,
        peis::special::kLinks, peis::special::kDoQuit}) {
    INFO(key);
    REQUIRE(k.get(key).has_value());
    CHECK(k.get(key)->owner == kId);
  }
  CHECK(dataOf(k, "kernel.name") == "tester");
  CHECK(dataOf(k, "kernel.id") == "42");
  CHECK(dataOf(k, "kernel.version") == peis::versionString());
  CHECK_FALSE(dataOf(k, "kernel.hostname").empty());
  CHECK_FALSE(dataOf(k, "kernel.user").empty());
  CHECK(dataOf(k, "kernel.do-quit") == "no");
  CHECK(dataOf(k, "kernel.subscribers").empty());
  CHECK(dataOf(k, "kernel.links").empty());

  const auto keys = words(dataOf(k, "kernel.all-keys"));
  for (const char* key :
       {"kernel.name", "kernel.id", "kernel.hostname", "kernel.user", "kernel.version",
        "kernel.all-keys", "kernel.subscribers", "kernel.links", "kernel.do-quit"}) {
    INFO(key);
    CHECK(contains(keys, key));
  }
  CHECK_FALSE(k.quitRequested());
  CHECK(k.callbackErrors() == 0);
}

TEST_CASE("kernel.all-keys follows the own keys", "[unit][kernel]") {
  std::mutex mu;
  std::vector<std::string> published;  // kernel.all-keys as seen by a callback
  peis::Kernel k(testOptions());
  k.onChange(peis::Pattern::exact(kId, "kernel.all-keys"), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    published.push_back(t.data);
  });
  auto publishedLastHas = [&](const std::string& key) {
    std::lock_guard lock(mu);
    return !published.empty() && contains(words(published.back()), key);
  };

  k.set("sensor.temp", "21.5");
  // The kernel thread rewrites kernel.all-keys by itself (no get() needed).
  CHECK(waitFor([&] { return publishedLastHas("sensor.temp"); }));
  CHECK(waitFor([&] { return contains(words(dataOf(k, "kernel.all-keys")), "sensor.temp"); }));

  k.set("sensor.humidity", "40");
  CHECK(waitFor([&] { return publishedLastHas("sensor.humidity"); }));
  const auto keys = words(dataOf(k, "kernel.all-keys"));
  CHECK(contains(keys, "sensor.temp"));
  CHECK(contains(keys, "sensor.humidity"));
  CHECK(std::is_sorted(keys.begin(), keys.end()));

  REQUIRE(k.erase("sensor.temp"));
  CHECK(waitFor([&] { return !contains(words(dataOf(k, "kernel.all-keys")), "sensor.temp"); }));
  CHECK(waitFor([&] {
    std::lock_guard lock(mu);
    return !published.empty() && !contains(words(published.back()), "sensor.temp") &&
           contains(words(published.back()), "sensor.humidity");
  }));
}

TEST_CASE("Kernel sets the --peis-set-tuple values at start", "[unit][kernel]") {
  auto o = testOptions();
  o.setTuples = {{"light.reqState", "on"}, {"greeting", "hello world"}, {"empty.value", ""}};
  peis::Kernel k(o);
  CHECK(dataOf(k, "light.reqState") == "on");
  CHECK(dataOf(k, "greeting") == "hello world");
  REQUIRE(k.get("empty.value").has_value());
  CHECK(k.get("empty.value")->data.empty());
  CHECK(k.get("greeting")->owner == kId);
  const auto keys = words(dataOf(k, "kernel.all-keys"));
  CHECK(contains(keys, "light.reqState"));
  CHECK(contains(keys, "greeting"));
}

TEST_CASE("Kernel takes its default name from the program name", "[unit][kernel]") {
  SECTION("a plain program name") {
    auto o = testOptions(7, "");
    o.programName = "camera_driver";
    peis::Kernel k(o);
    CHECK(k.name() == "camera_driver");
    CHECK(dataOf(k, "kernel.name") == "camera_driver");
  }
  SECTION("characters a name may not hold become dashes") {
    auto o = testOptions(7, "");
    o.programName = "my prog.v2*x=y";
    peis::Kernel k(o);
    CHECK(k.name() == "my-prog-v2-x-y");
    CHECK_FALSE(peis::nameProblem(k.name()).has_value());
  }
  SECTION("no usable program name: peis-<id>") {
    auto o = testOptions(7, "");
    SECTION("empty") { o.programName = ""; }
    SECTION("all digits") { o.programName = "12345"; }
    peis::Kernel k(o);
    CHECK(k.name() == "peis-7");
    CHECK(dataOf(k, "kernel.name") == "peis-7");
  }
  SECTION("an explicit name wins") {
    auto o = testOptions(7, "");
    o.programName = "camera_driver";
    o.name = "Astrid";
    peis::Kernel k(o);
    CHECK(k.name() == "Astrid");
  }
}

TEST_CASE("Kernel set and get stamp and return tuples", "[unit][kernel]") {
  peis::Kernel k(testOptions());
  const auto first = k.set("sensor.temp", "21.5");
  CHECK(first.owner == kId);
  CHECK(first.creator == kId);
  CHECK(first.key == "sensor.temp");
  CHECK(first.data == "21.5");
  CHECK(first.mimetype == peis::kDefaultMimetype);
  CHECK(first.seqno == 1);
  CHECK(first.ts_write != peis::kNoTime);
  CHECK(first.ts_expire == peis::kNoTime);
  REQUIRE(k.get("sensor.temp").has_value());
  CHECK(*k.get("sensor.temp") == first);
  CHECK(*k.get(kId, "sensor.temp") == first);

  peis::WriteOptions w;
  w.mimetype = "application/json";
  w.ts_user = peis::Timestamp(std::chrono::seconds(1'700'000'000));
  const auto second = k.set("sensor.temp", "{\"c\": 22}", w);
  CHECK(second.seqno == 2);
  CHECK(second.mimetype == "application/json");
  CHECK(second.ts_user == w.ts_user);
  CHECK(second.ts_write >= first.ts_write);
  CHECK(*k.get("sensor.temp") == second);

  CHECK_FALSE(k.get("never.set").has_value());
  CHECK_FALSE(k.get(kId + 1, "sensor.temp").has_value());
  CHECK_THROWS_MATCHES(k.set("bad key", "x"), peis::Error, HasCode(ErrorCode::InvalidKey));
  CHECK_THROWS_MATCHES(k.set("", "x"), peis::Error, HasCode(ErrorCode::InvalidKey));
  CHECK_THROWS_MATCHES(k.set("a.*", "x"), peis::Error, HasCode(ErrorCode::InvalidKey));
}

TEST_CASE("Kernel publish writes like set and returns the seqno", "[unit][kernel]") {
  peis::Kernel k(testOptions());
  std::atomic<int> seen{0};
  std::atomic<std::uint64_t> lastSeen{0};
  k.onChange(peis::Pattern::exact(kId, "stream"), [&](const peis::Tuple& t) {
    lastSeen = t.seqno;
    ++seen;
  });
  CHECK(k.publish("stream", "a") == 1);
  peis::WriteOptions w;
  w.mimetype = "application/json";
  CHECK(k.publish("stream", "[2]", w) == 2);
  CHECK(k.set("stream", "c").seqno == 3);  // one sequence with set
  CHECK(k.publish("stream", std::string(70000, 'x')) == 4);
  const auto stored = k.get("stream");
  REQUIRE(stored.has_value());
  CHECK(stored->seqno == 4);
  CHECK(stored->data.size() == 70000);
  CHECK(stored->mimetype == peis::kDefaultMimetype);
  CHECK(stored->owner == kId);
  CHECK(stored->ts_write != peis::kNoTime);
  CHECK_THROWS_MATCHES(k.publish("bad key", "x"), peis::Error, HasCode(ErrorCode::InvalidKey));
  CHECK(waitFor([&] { return seen == 4; }, 10s));  // every write delivered, in order
  CHECK(lastSeen == 4);
}

TEST_CASE("Kernel find returns the live tuples a pattern matches", "[unit][kernel]") {
  peis::Kernel k(testOptions());
  k.set("sensor.temp", "21");
  k.set("sensor.humidity", "40");
  k.set("sensor.deep.value", "1");
  k.set("other", "x");

  auto keysOf = [](const std::vector<peis::Tuple>& tuples) {
    std::set<std::string> keys;
    for (const auto& t : tuples) keys.insert(t.key);
    return keys;
  };
  CHECK(keysOf(k.find(peis::Pattern("sensor.*"))) ==
        std::set<std::string>{"sensor.temp", "sensor.humidity"});
  CHECK(keysOf(k.find(peis::Pattern("sensor.**"))) ==
        std::set<std::string>{"sensor.temp", "sensor.humidity", "sensor.deep.value"});
  CHECK(keysOf(k.find(peis::Pattern("sensor.*", kId))) ==
        std::set<std::string>{"sensor.temp", "sensor.humidity"});
  CHECK(k.find(peis::Pattern("sensor.*", kId + 1)).empty());
  CHECK(k.find(peis::Pattern("nothing.here")).empty());

  const auto found = k.find(peis::Pattern::exact(kId, "other"));
  REQUIRE(found.size() == 1);
  CHECK(found[0] == *k.get("other"));

  k.erase("sensor.temp");
  CHECK(keysOf(k.find(peis::Pattern("sensor.*"))) == std::set<std::string>{"sensor.humidity"});
}

TEST_CASE("Kernel erase, append and setDefault", "[unit][kernel]") {
  peis::Kernel k(testOptions());

  SECTION("erase") {
    const auto a = k.set("x", "1");
    CHECK(k.erase("x"));
    CHECK_FALSE(k.get("x").has_value());
    CHECK_FALSE(k.erase("x"));
    CHECK_FALSE(k.erase("never.set"));
    // A re-created key keeps increasing its seqno.
    const auto b = k.set("x", "2");
    CHECK(b.seqno > a.seqno + 1);
    CHECK_THROWS_MATCHES(k.erase("bad key"), peis::Error, HasCode(ErrorCode::InvalidKey));
  }

  SECTION("append") {
    const auto a = k.append("log", "a");
    CHECK(a.data == "a");
    CHECK(a.seqno == 1);
    const auto b = k.append("log", "b", a.seqno);
    CHECK(b.data == "ab");
    CHECK(b.seqno == 2);
    CHECK_THROWS_MATCHES(k.append("log", "c", a.seqno), peis::Error, HasCode(ErrorCode::Conflict));
    CHECK(dataOf(k, "log") == "ab");
    CHECK(k.append("log", "c").data == "abc");
    // ifSeqno 0: only when the key has never been written.
    CHECK(k.append("fresh", "x", 0).data == "x");
    CHECK_THROWS_MATCHES(k.append("fresh", "y", 0), peis::Error, HasCode(ErrorCode::Conflict));
    // An append keeps the tuple's mimetype.
    peis::WriteOptions json;
    json.mimetype = "application/json";
    k.set("doc", "[1", json);
    CHECK(k.append("doc", "]").mimetype == "application/json");
    CHECK(dataOf(k, "doc") == "[1]");
  }

  SECTION("setDefault") {
    CHECK(k.setDefault("mode", "auto"));
    CHECK(dataOf(k, "mode") == "auto");
    CHECK_FALSE(k.setDefault("mode", "manual"));
    CHECK(dataOf(k, "mode") == "auto");
    CHECK(k.get("mode")->seqno == 1);
    k.erase("mode");
    CHECK(k.setDefault("mode", "manual"));
    CHECK(dataOf(k, "mode") == "manual");
  }
}

TEST_CASE("Kernel enforces the data limit of its options", "[unit][kernel]") {
  constexpr std::size_t kLimit = 256;  // above any hostname or user name
  auto o = testOptions();
  o.maxDataBytes = kLimit;
  peis::Kernel k(o);
  const std::string full(kLimit, 'x');
  CHECK(k.set("fits", full).data.size() == kLimit);
  CHECK_THROWS_MATCHES(k.set("big", full + "x"), peis::Error, HasCode(ErrorCode::TooLarge));
  CHECK_FALSE(k.get("big").has_value());
  CHECK_THROWS_MATCHES(k.set("fits", full + "y"), peis::Error, HasCode(ErrorCode::TooLarge));
  CHECK(dataOf(k, "fits") == full);
  CHECK_THROWS_MATCHES(k.append("fits", "z"), peis::Error, HasCode(ErrorCode::TooLarge));
  CHECK(dataOf(k, "fits") == full);
  CHECK_THROWS_MATCHES(k.setDefault("other", full + "x"), peis::Error,
                       HasCode(ErrorCode::TooLarge));
  CHECK_FALSE(k.get("other").has_value());
  CHECK(k.get("fits")->seqno == 1);
}

TEST_CASE("Kernel rejects a --peis-set-tuple value over the data limit", "[unit][kernel]") {
  auto o = testOptions();
  o.maxDataBytes = 256;
  o.setTuples = {{"too.big", std::string(257, 'x')}};
  CHECK_THROWS_MATCHES(peis::Kernel(o), peis::Error, HasCode(ErrorCode::TooLarge));
}

TEST_CASE("kernel.all-keys is not limited by the data limit", "[unit][kernel]") {
  std::atomic<int> marker{0};
  auto o = testOptions();
  o.maxDataBytes = 256;
  peis::Kernel k(o);
  k.onChange(peis::Pattern::exact(kId, "last.key"), [&](const peis::Tuple&) { ++marker; });
  // 40 keys of 16 bytes: the list of own keys grows well over 256 bytes.
  for (int i = 0; i < 40; ++i) k.set("many.keys.k" + std::to_string(1000 + i), "v");
  k.set("last.key", "v");
  REQUIRE(waitFor([&] { return marker == 1; }));
  REQUIRE(fence(k));
  const auto keys = words(dataOf(k, "kernel.all-keys"));
  CHECK(contains(keys, "many.keys.k1000"));
  CHECK(contains(keys, "many.keys.k1039"));
  CHECK(contains(keys, "last.key"));
  CHECK(dataOf(k, "kernel.all-keys").size() > 256);
  CHECK(k.set("still.working", "yes").data == "yes");
}

TEST_CASE("Kernel cannot write to another owner without a link", "[unit][kernel]") {
  peis::Kernel k(testOptions());
  CHECK_THROWS_MATCHES(k.set(kId + 1, "light.reqState", "on"), peis::Error,
                       HasCode(ErrorCode::Unreachable));
  CHECK_FALSE(k.get(kId + 1, "light.reqState").has_value());
  CHECK_THROWS_MATCHES(k.setMeta(kId + 1, "mi-pos", kId, "tracker.pos"), peis::Error,
                       HasCode(ErrorCode::Unreachable));
  // Writing to the own id through the owner overload is a plain set.
  const auto own = k.set(kId, "light.reqState", "on");
  CHECK(own.owner == kId);
  CHECK(dataOf(k, "light.reqState") == "on");
}

TEST_CASE("Kernel get by full name resolves ids and its own name", "[unit][kernel]") {
  peis::Kernel k(testOptions());
  k.set("position.x", "1.5");

  const auto byId = k.get(peis::parseFullName("42.position.x"));
  REQUIRE(byId.has_value());
  CHECK(byId->data == "1.5");

  const auto byName = k.get(peis::parseFullName("tester.position.x"));
  REQUIRE(byName.has_value());
  CHECK(*byName == *byId);

  CHECK(k.resolveOwner("tester") == kId);
  CHECK(k.resolveOwner("42") == kId);
  CHECK_FALSE(k.get(peis::parseFullName("42.position.y")).has_value());
  CHECK_FALSE(k.get(peis::parseFullName("43.position.x")).has_value());
  CHECK_THROWS_MATCHES(k.get(peis::parseFullName("nobody.position.x")), peis::Error,
                       HasCode(ErrorCode::NotFound));
}

TEST_CASE("Kernel callbacks run on the kernel thread and may call the API", "[unit][kernel]") {
  std::mutex mu;
  std::vector<std::string> seenB;
  std::atomic<bool> aOnKernelThread{false}, bOnKernelThread{false};
  std::atomic<int> deleted{0};
  peis::Kernel k(testOptions());
  CHECK_FALSE(k.onKernelThread());

  k.onChange(peis::Pattern::exact(kId, "chain.a"), [&](const peis::Tuple& t) {
    aOnKernelThread = k.onKernelThread();
    k.set("chain.b", t.data + "!");
  });
  k.onChange(peis::Pattern::exact(kId, "chain.b"), [&](const peis::Tuple& t) {
    bOnKernelThread = k.onKernelThread();
    std::lock_guard lock(mu);
    seenB.push_back(t.data);
  });
  k.onDelete(peis::Pattern("chain.*"), [&](const peis::Tuple& t) {
    if (k.onKernelThread() && t.key == "chain.b") ++deleted;
  });

  k.set("chain.a", "hello");
  REQUIRE(waitFor([&] {
    std::lock_guard lock(mu);
    return !seenB.empty();
  }));
  {
    std::lock_guard lock(mu);
    CHECK(seenB == std::vector<std::string>{"hello!"});
  }
  CHECK(aOnKernelThread);
  CHECK(bOnKernelThread);
  CHECK(dataOf(k, "chain.b") == "hello!");

  k.erase("chain.b");
  CHECK(waitFor([&] { return deleted == 1; }));
  CHECK(k.callbackErrors() == 0);
}

TEST_CASE("Kernel onChange and onDelete see only their events", "[unit][kernel]") {
  std::mutex mu;
  std::vector<std::string> changes, deletes;
  peis::Kernel k(testOptions());
  k.onChange(peis::Pattern("door.*"), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    changes.push_back(t.key + "=" + t.data);
  });
  k.onDelete(peis::Pattern("door.*"), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    deletes.push_back(t.key + "=" + t.data);
  });
  k.set("door.front", "open");
  k.set("window.front", "open");
  k.set("door.front", "closed");
  k.erase("door.front");
  k.set("door.back", "open");
  REQUIRE(waitFor([&] {
    std::lock_guard lock(mu);
    return changes.size() == 3 && deletes.size() == 1;
  }));
  std::lock_guard lock(mu);
  CHECK(changes ==
        std::vector<std::string>{"door.front=open", "door.front=closed", "door.back=open"});
  CHECK(deletes == std::vector<std::string>{"door.front=closed"});
}

TEST_CASE("Kernel onValue starts with the values held, then every change, each once",
          "[unit][kernel]") {
  std::mutex mu;
  std::vector<std::string> values, changes;
  peis::Kernel k(testOptions());
  k.set("door.front", "open");
  k.set("door.back", "closed");
  k.set("window.front", "open");
  k.onChange(peis::Pattern("door.*"), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    changes.push_back(t.key + "=" + t.data);
  });
  k.onValue(peis::Pattern("door.*"), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    values.push_back(t.key + "=" + t.data);
  });
  k.set("door.front", "closed");
  REQUIRE(waitFor([&] {
    std::lock_guard lock(mu);
    return values.size() == 3 && changes.size() == 1;
  }));
  std::lock_guard lock(mu);
  // The held ones first (in key order), then the change; onChange only the change.
  CHECK(values ==
        std::vector<std::string>{"door.back=closed", "door.front=open", "door.front=closed"});
  CHECK(changes == std::vector<std::string>{"door.front=closed"});
}

TEST_CASE("Kernel callback that removes itself is not called again", "[unit][kernel]") {
  std::atomic<int> selfCalls{0}, markerCalls{0};
  std::atomic<peis::CallbackHandle> handle{0};
  std::atomic<bool> removed{false}, removedAgain{true};
  peis::Kernel k(testOptions());
  handle = k.onChange(peis::Pattern::exact(kId, "once"), [&](const peis::Tuple&) {
    ++selfCalls;
    removed = k.removeCallback(handle);
    removedAgain = k.removeCallback(handle);
  });
  // Registered later, so it runs after the self-removing one for each event.
  k.onChange(peis::Pattern::exact(kId, "once"), [&](const peis::Tuple&) { ++markerCalls; });

  k.set("once", "1");
  k.set("once", "2");
  k.set("once", "3");
  REQUIRE(waitFor([&] { return markerCalls == 3; }));
  CHECK(selfCalls == 1);
  CHECK(removed);
  CHECK_FALSE(removedAgain);
  CHECK_FALSE(k.removeCallback(handle));
}

TEST_CASE("Kernel removeCallback from another thread stops the callback", "[unit][kernel]") {
  std::atomic<int> calls{0}, markerCalls{0};
  peis::Kernel k(testOptions());
  const auto handle =
      k.onChange(peis::Pattern::exact(kId, "k"), [&](const peis::Tuple&) { ++calls; });
  k.onChange(peis::Pattern::exact(kId, "k"), [&](const peis::Tuple&) { ++markerCalls; });
  k.set("k", "1");
  REQUIRE(waitFor([&] { return markerCalls == 1 && calls == 1; }));
  CHECK(k.removeCallback(handle));
  k.set("k", "2");
  REQUIRE(waitFor([&] { return markerCalls == 2; }));
  CHECK(calls == 1);
}

TEST_CASE("Kernel removeCallback while events are being delivered", "[unit][kernel]") {
  std::atomic<long> calls{0}, markerCalls{0}, delivered{0}, written{0};
  peis::Kernel k(testOptions());
  k.onChange(peis::Pattern("busy.*"), [&](const peis::Tuple&) { ++delivered; });
  std::vector<peis::CallbackHandle> handles;
  for (int i = 0; i < 8; ++i) {
    handles.push_back(k.onChange(peis::Pattern("busy.*"), [&](const peis::Tuple&) { ++calls; }));
  }
  // Keeps up to 64 events in flight (no more, so the kernel thread keeps up).
  Writer writer([&] {
    if (written - delivered < 64) {
      k.set("busy.key", std::to_string(++written));
    } else {
      std::this_thread::yield();
    }
  });
  REQUIRE(waitFor([&] { return calls > 100; }));
  for (auto handle : handles) CHECK(k.removeCallback(handle));
  // Events queued from here on no longer match the removed callbacks; once a
  // callback registered now has run, no delivery in flight is left to them.
  const auto marker =
      k.onChange(peis::Pattern("busy.*"), [&](const peis::Tuple&) { ++markerCalls; });
  REQUIRE(waitFor([&] { return markerCalls > 10; }));
  const long after = calls;
  REQUIRE(waitFor([&] { return markerCalls > 20; }));
  CHECK(calls == after);
  writer.stop();
  CHECK(k.removeCallback(marker));
}

TEST_CASE("Kernel blocking get in a callback fails with WouldDeadlock", "[unit][kernel]") {
  std::mutex mu;
  std::optional<ErrorCode> code;
  bool returned = false;
  peis::Kernel k(testOptions());
  k.onChange(peis::Pattern::exact(kId, "trigger"), [&](const peis::Tuple&) {
    try {
      k.get(kId, "never.set", 10s);
      std::lock_guard lock(mu);
      returned = true;
    } catch (const peis::Error& e) {
      std::lock_guard lock(mu);
      code = e.code();
    }
  });
  k.set("trigger", "go");
  REQUIRE(waitFor([&] {
    std::lock_guard lock(mu);
    return code.has_value() || returned;
  }));
  std::lock_guard lock(mu);
  CHECK_FALSE(returned);
  REQUIRE(code.has_value());
  CHECK(*code == ErrorCode::WouldDeadlock);
  CHECK(k.callbackErrors() == 0);
}

TEST_CASE("Kernel counts a throwing callback and keeps working", "[unit][kernel]") {
  std::atomic<int> otherCalls{0}, laterCalls{0}, indirectCalls{0};
  peis::Kernel k(testOptions());
  k.onChange(peis::Pattern::exact(kId, "boom"),
             [](const peis::Tuple&) { throw std::runtime_error("callback failed on purpose"); });
  // The other callbacks for the same event still get it.
  k.onChange(peis::Pattern::exact(kId, "boom"), [&](const peis::Tuple&) { ++otherCalls; });
  k.onChange(peis::Pattern::exact(kId, "later"), [&](const peis::Tuple&) { ++laterCalls; });

  k.set("boom", "1");
  REQUIRE(waitFor([&] { return k.callbackErrors() == 1; }));
  CHECK(waitFor([&] { return otherCalls == 1; }));

  k.set("later", "x");
  CHECK(waitFor([&] { return laterCalls == 1; }));
  k.set("boom", "2");
  CHECK(waitFor([&] { return k.callbackErrors() == 2 && otherCalls == 2; }));

  SECTION("each throwing callback counts, whatever it throws") {
    k.onChange(peis::Pattern("boom"), [](const peis::Tuple&) { throw 7; });
    k.setMeta("meta.boom", kId, "boom");
    k.subscribeIndirect(kId, "meta.boom", [&](const peis::Tuple& t) {
      if (t.data == "3") ++indirectCalls;
    });
    k.set("boom", "3");
    CHECK(waitFor([&] { return k.callbackErrors() == 4 && otherCalls == 3; }));
    CHECK(waitFor([&] { return indirectCalls == 1; }));
  }

  CHECK(k.set("still.working", "yes").data == "yes");
  CHECK(fence(k));
}

TEST_CASE("Kernel is thread-safe under concurrent writers", "[unit][kernel]") {
  constexpr int kThreads = 4;
  constexpr int kWrites = 2000;
  std::atomic<long> changes{0};
  std::mutex mu;
  std::vector<std::uint64_t> sharedSeqnos;
  bool sharedInOrder = true;
  peis::Kernel k(testOptions());
  k.onChange(peis::Pattern("stress.*"), [&](const peis::Tuple&) { ++changes; });
  k.onChange(peis::Pattern::exact(kId, "stress.shared"), [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    if (!sharedSeqnos.empty() && t.seqno <= sharedSeqnos.back()) sharedInOrder = false;
    sharedSeqnos.push_back(t.seqno);
  });

  std::vector<std::thread> writers;
  for (int w = 0; w < kThreads; ++w) {
    writers.emplace_back([&k, w] {
      const auto own = "stress.t" + std::to_string(w);
      for (int i = 0; i < kWrites; ++i) {
        k.set(own, std::to_string(i));
        k.set("stress.shared", std::to_string(w) + ":" + std::to_string(i));
      }
    });
  }
  for (auto& t : writers) t.join();

  constexpr long kTotal = 2L * kThreads * kWrites;
  REQUIRE(waitFor([&] { return changes.load() >= kTotal; }, 30s));
  CHECK(fence(k));
  CHECK(changes == kTotal);
  for (int w = 0; w < kThreads; ++w) {
    const auto t = k.get("stress.t" + std::to_string(w));
    REQUIRE(t.has_value());
    CHECK(t->seqno == kWrites);
    CHECK(t->data == std::to_string(kWrites - 1));
  }
  REQUIRE(k.get("stress.shared").has_value());
  CHECK(k.get("stress.shared")->seqno == static_cast<std::uint64_t>(kThreads) * kWrites);
  std::lock_guard lock(mu);
  CHECK(sharedInOrder);
  CHECK(sharedSeqnos.size() == static_cast<std::size_t>(kThreads) * kWrites);
  CHECK(sharedSeqnos.back() == static_cast<std::uint64_t>(kThreads) * kWrites);
  CHECK(k.callbackErrors() == 0);
}

TEST_CASE("Kernel blocking get waits for a value", "[unit][kernel]") {
  peis::Kernel k(testOptions());

  SECTION("another thread sets the key") {
    std::thread writer([&k] { k.set("later.value", "arrived"); });
    const auto got = k.get(kId, "later.value", 10s);
    writer.join();
    REQUIRE(got.has_value());
    CHECK(got->data == "arrived");
  }

  SECTION("the kernel thread sets the key after a delay") {
    k.after(30ms, [&k] { k.set("later.value", "from a timer"); });
    const auto got = k.get(kId, "later.value", 10s);
    REQUIRE(got.has_value());
    CHECK(got->data == "from a timer");
  }

  SECTION("a value already there is returned at once") {
    k.set("later.value", "here");
    const auto got = k.get(kId, "later.value", 10s);
    REQUIRE(got.has_value());
    CHECK(got->data == "here");
  }

  SECTION("nothing at the deadline") {
    CHECK_FALSE(k.get(kId, "never.set", 50ms).has_value());
    CHECK_FALSE(k.get(kId, "never.set", 0ms).has_value());
    CHECK_FALSE(k.get(kId + 1, "never.set", 20ms).has_value());
  }
}

TEST_CASE("Kernel expires tuples on its own thread", "[unit][kernel]") {
  std::mutex mu;
  std::vector<peis::Tuple> deleted;
  std::atomic<bool> onKernelThread{false};
  peis::Kernel k(testOptions());
  k.onDelete(peis::Pattern("short.*"), [&](const peis::Tuple& t) {
    onKernelThread = k.onKernelThread();
    std::lock_guard lock(mu);
    deleted.push_back(t);
  });

  peis::WriteOptions longLived;
  longLived.ttl = std::chrono::hours(1);
  k.set("short.long", "stays", longLived);  // a later expiry scheduled first
  peis::WriteOptions shortLived;
  shortLived.ttl = 20ms;
  const auto written = k.set("short.lived", "soon gone", shortLived);
  CHECK(written.ts_expire != peis::kNoTime);
  CHECK(written.ts_expire > written.ts_write);

  REQUIRE(waitFor([&] {
    std::lock_guard lock(mu);
    return !deleted.empty();
  }));
  CHECK(onKernelThread);
  CHECK_FALSE(k.get("short.lived").has_value());
  CHECK(k.find(peis::Pattern("short.lived")).empty());
  CHECK(waitFor([&] { return !contains(words(dataOf(k, "kernel.all-keys")), "short.lived"); }));
  CHECK(dataOf(k, "short.long") == "stays");
  std::lock_guard lock(mu);
  REQUIRE(deleted.size() == 1);
  CHECK(deleted[0].key == "short.lived");
  CHECK(deleted[0].data == "soon gone");
  CHECK(deleted[0].seqno > written.seqno);
}

TEST_CASE("Kernel timers: after, every and cancelTimer", "[unit][kernel]") {
  std::atomic<int> afterCalls{0}, everyCalls{0}, cancelledCalls{0}, otherCalls{0};
  std::atomic<bool> afterOnKernelThread{false}, postOnKernelThread{false};
  peis::Kernel k(testOptions());

  SECTION("after runs once on the kernel thread") {
    k.after(10ms, [&] {
      afterOnKernelThread = k.onKernelThread();
      ++afterCalls;
    });
    REQUIRE(waitFor([&] { return afterCalls == 1; }));
    CHECK(afterOnKernelThread);
    // Another timer that fires later proves the first did not run again.
    k.after(20ms, [&] { ++otherCalls; });
    REQUIRE(waitFor([&] { return otherCalls == 1; }));
    CHECK(afterCalls == 1);
  }

  SECTION("a cancelled after never runs") {
    const auto handle = k.after(std::chrono::hours(1), [&] { ++cancelledCalls; });
    CHECK(k.cancelTimer(handle));
    CHECK_FALSE(k.cancelTimer(handle));
    k.after(20ms, [&] { ++otherCalls; });
    REQUIRE(waitFor([&] { return otherCalls == 1; }));
    CHECK(fence(k));
    CHECK(cancelledCalls == 0);
  }

  SECTION("an after that is due races cancelTimer: exactly one of them wins") {
    constexpr int kTimers = 50;
    std::vector<std::atomic<int>> runs(kTimers);
    std::vector<bool> cancelled(kTimers);
    std::vector<peis::TimerHandle> handles;
    for (int i = 0; i < kTimers; ++i) handles.push_back(k.after(0ms, [&runs, i] { ++runs[i]; }));
    for (int i = 0; i < kTimers; ++i) cancelled[i] = k.cancelTimer(handles[i]);
    k.after(20ms, [&] { ++otherCalls; });
    REQUIRE(waitFor([&] { return otherCalls == 1; }));
    REQUIRE(fence(k));
    for (int i = 0; i < kTimers; ++i) {
      INFO("timer " << i);
      CHECK(runs[i] == (cancelled[i] ? 0 : 1));
    }
  }

  SECTION("a timer that fired can no longer be cancelled") {
    const auto handle = k.after(0ms, [&] { ++afterCalls; });
    REQUIRE(waitFor([&] { return afterCalls == 1; }));
    CHECK_FALSE(k.cancelTimer(handle));
  }

  SECTION("every repeats until cancelled") {
    const auto handle = k.every(5ms, [&] { ++everyCalls; });
    REQUIRE(waitFor([&] { return everyCalls >= 3; }));
    CHECK(k.cancelTimer(handle));
    CHECK_FALSE(k.cancelTimer(handle));
    REQUIRE(fence(k));  // a run that was in progress has finished
    const int stopped = everyCalls;
    k.after(50ms, [&] { ++otherCalls; });
    REQUIRE(waitFor([&] { return otherCalls == 1; }));
    CHECK(everyCalls == stopped);
  }

  SECTION("every cancelled from its own callback") {
    std::atomic<peis::TimerHandle> handle{0};
    std::atomic<bool> cancelled{false};
    handle = k.every(5ms, [&] {
      if (++everyCalls == 2) cancelled = k.cancelTimer(handle);
    });
    REQUIRE(waitFor([&] { return cancelled.load(); }));
    k.after(40ms, [&] { ++otherCalls; });
    REQUIRE(waitFor([&] { return otherCalls == 1; }));
    CHECK(everyCalls == 2);
  }

  SECTION("post runs on the kernel thread") {
    std::atomic<bool> ran{false};
    k.post([&] {
      postOnKernelThread = k.onKernelThread();
      ran = true;
    });
    REQUIRE(waitFor([&] { return ran.load(); }));
    CHECK(postOnKernelThread);
  }

  SECTION("bad arguments") {
    CHECK_THROWS_MATCHES(k.every(0ms, [] {}), peis::Error, HasCode(ErrorCode::InvalidArgument));
    CHECK_FALSE(k.cancelTimer(987654));
  }

  SECTION("a throwing timer is counted and the kernel keeps working") {
    k.after(0ms, [] { throw std::runtime_error("timer failed on purpose"); });
    REQUIRE(waitFor([&] { return k.callbackErrors() == 1; }));
    k.after(0ms, [] { throw 42; });  // not even a std::exception
    REQUIRE(waitFor([&] { return k.callbackErrors() == 2; }));
    k.post([] { throw std::runtime_error("posted function failed on purpose"); });
    REQUIRE(waitFor([&] { return k.callbackErrors() == 3; }));
    k.after(0ms, [&] { ++afterCalls; });
    CHECK(waitFor([&] { return afterCalls == 1; }));
  }
}

TEST_CASE("Kernel quits when kernel.do-quit is set to yes", "[unit][kernel]") {
  peis::Kernel k(testOptions());
  CHECK_FALSE(k.runFor(10ms));  // a deadline, not a timing check
  CHECK_FALSE(k.quitRequested());

  k.set("kernel.do-quit", "maybe");
  REQUIRE(fence(k));  // the do-quit callback has seen the value
  CHECK_FALSE(k.quitRequested());

  k.set("kernel.do-quit", "yes");
  CHECK(k.runFor(10s));
  CHECK(k.quitRequested());
  CHECK(k.runFor(0ms));
  // The kernel still answers after a quit request.
  CHECK(k.set("after.quit", "ok").data == "ok");
}

TEST_CASE("Kernel quit() ends run() in another thread", "[unit][kernel]") {
  std::string reason;
  peis::Kernel k(testOptions());
  std::thread runner([&] { reason = k.run(); });
  k.quit("the test is over");
  runner.join();
  CHECK(reason == "the test is over");
  CHECK(k.quitRequested());
  // A second quit does not change the reason.
  k.quit("again");
  CHECK(k.run() == "the test is over");
}

TEST_CASE("Kernel indirect subscription follows a re-pointed meta tuple", "[unit][kernel]") {
  struct Seen {
    std::mutex mu;
    std::map<std::string, std::vector<std::uint64_t>> seqnos;  // per target key
    std::map<std::string, int> sinceRepoint;
    bool duplicate = false;
    bool outOfOrder = false;
    std::string lastKey, lastData;
  } seen;
  std::atomic<long> delivered{0}, written{0};
  peis::Kernel k(testOptions());
  k.onChange(peis::Pattern("target.*"), [&](const peis::Tuple&) { ++delivered; });

  k.set("target.a", "a0");
  k.set("target.b", "b0");
  k.setMeta("meta.x", kId, "target.a");
  REQUIRE(k.resolveMeta(kId, "meta.x").has_value());
  CHECK(k.resolveMeta(kId, "meta.x")->key == "target.a");
  CHECK(k.getIndirect(kId, "meta.x")->data == "a0");

  k.subscribeIndirect(kId, "meta.x", [&](const peis::Tuple& t) {
    std::lock_guard lock(seen.mu);
    auto& list = seen.seqnos[t.key];
    if (std::find(list.begin(), list.end(), t.seqno) != list.end()) seen.duplicate = true;
    if (!list.empty() && t.seqno < list.back()) seen.outOfOrder = true;
    list.push_back(t.seqno);
    ++seen.sinceRepoint[t.key];
    seen.lastKey = t.key;
    seen.lastData = t.data;
  });

  // Writes both targets in turn, with at most 64 events in flight.
  long round = 0;
  Writer producer([&] {
    if (written - delivered < 64) {
      ++round;
      k.set("target.a", "a" + std::to_string(round));
      k.set("target.b", "b" + std::to_string(round));
      written += 2;
    } else {
      std::this_thread::yield();
    }
  });

  // Waits until the subscription has seen a few values of `key` since the last
  // re-point: the producer has moved on (also on the other target).
  auto seesProgressOn = [&](const std::string& key) {
    return waitFor([&] {
      std::lock_guard lock(seen.mu);
      return seen.sinceRepoint[key] >= 3 && seen.lastKey == key;
    });
  };
  auto repoint = [&](const std::string& key) {
    {
      std::lock_guard lock(seen.mu);
      seen.sinceRepoint.clear();
    }
    k.setMeta("meta.x", kId, key);
  };

  CHECK(seesProgressOn("target.a"));
  const std::vector<std::string> order = {"target.b", "target.a", "target.b", "target.a",
                                          "target.b"};
  for (const auto& key : order) {
    repoint(key);
    CHECK(seesProgressOn(key));
  }
  producer.stop();

  const auto last = k.get("target.b");
  REQUIRE(last.has_value());
  CHECK(waitFor([&] {
    std::lock_guard lock(seen.mu);
    return seen.lastKey == "target.b" && seen.lastData == last->data;
  }));
  CHECK(fence(k));
  std::lock_guard lock(seen.mu);
  CHECK_FALSE(seen.duplicate);
  CHECK_FALSE(seen.outOfOrder);
  CHECK(seen.lastKey == "target.b");
  CHECK(seen.lastData == last->data);
  CHECK(seen.seqnos["target.b"].back() == last->seqno);
  CHECK(k.getIndirect(kId, "meta.x")->data == last->data);
  CHECK(k.callbackErrors() == 0);
}

TEST_CASE("Kernel indirect subscription delivers the new target's value at once",
          "[unit][kernel]") {
  std::mutex mu;
  std::vector<std::string> values;
  peis::Kernel k(testOptions());
  k.declareMeta("meta.y");
  REQUIRE(k.get("meta.y").has_value());
  CHECK(k.get("meta.y")->mimetype == peis::kMetaMimetype);
  CHECK_FALSE(k.resolveMeta(kId, "meta.y").has_value());
  CHECK_FALSE(k.getIndirect(kId, "meta.y").has_value());
  CHECK_THROWS_MATCHES(k.setIndirect(kId, "meta.y", "x"), peis::Error,
                       HasCode(ErrorCode::NotFound));

  k.subscribeIndirect(kId, "meta.y", [&](const peis::Tuple& t) {
    std::lock_guard lock(mu);
    values.push_back(t.key + "=" + t.data);
  });
  k.set("src.one", "1");
  k.setMeta("meta.y", kId, "src.one");
  REQUIRE(waitFor([&] {
    std::lock_guard lock(mu);
    return values.size() == 1;
  }));
  k.setIndirect(kId, "meta.y", "2");
  CHECK(dataOf(k, "src.one") == "2");
  k.set("src.two", "other");
  k.setMeta("meta.y", kId, "src.two");
  k.set("src.one", "3");  // no longer followed
  k.set("src.two", "again");
  REQUIRE(waitFor([&] {
    std::lock_guard lock(mu);
    return values.size() == 4;
  }));
  REQUIRE(fence(k));
  std::lock_guard lock(mu);
  CHECK(values ==
        std::vector<std::string>{"src.one=1", "src.one=2", "src.two=other", "src.two=again"});
}

// Durations longer than a timer can count (issue 9): they used to wrap into
// the past, so the timer fired at once (and a periodic one without end).
TEST_CASE("timers and waits longer than a timer's range do not fire at once", "[unit][kernel]") {
  peis::Kernel k(testOptions());
  std::atomic<int> farFired{0};
  std::atomic<bool> nearFired{false};
  std::atomic<int> farWhenNear{-1};
  k.every(std::chrono::milliseconds::max(), [&] { ++farFired; });
  k.after(std::chrono::milliseconds::max() - 1ms, [&] { ++farFired; });
  k.after(20ms, [&] {
    farWhenNear = farFired.load();
    nearFired = true;
  });
  REQUIRE(waitFor([&] { return nearFired.load(); }));
  CHECK(farWhenNear == 0);

  // A blocking get with the longest wait still waits for the value.
  k.after(50ms, [&] { k.set("late", "here"); });
  const auto late = k.get(kId, "late", std::chrono::milliseconds::max());
  REQUIRE(late);
  CHECK(late->data == "here");
  k.after(50ms, [&] { k.quit("the test is over"); });
  CHECK(k.runFor(std::chrono::milliseconds::max()));
}
