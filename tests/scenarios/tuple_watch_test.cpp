// TupleWatch (scenarios/src/tuple_watch.h): a watched tuple's current value
// is an event even when another subscription of the same PEIS (the runner's
// `**` for the trace) brought it before the watch's callbacks existed — the
// cause of the runner's flaky "the blind closes" / "the parcel weighs": a
// one-shot value, already cached, came again with the same seqno on the
// fresh subscription, which the kernel rightly does not call a change.
#include "tuple_watch.h"

#include <peis/kernel.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <mutex>

#include "support/integration.h"
#include "support/process.h"
#include "support/wait_for.h"

using namespace peis;
using namespace peis::test;
using namespace std::chrono_literals;

TEST_CASE("tuple watch: a value another subscription brought first is handed on, once",
          "[integration][scenario]") {
  const auto ecology = uniqueEcology("tuple-watch");
  Kernel owner(kernelOptions(ecology, "blind"));
  owner.set("BlindPosition", "0");  // written once, never again
  Kernel watcher(kernelOptions(ecology, "runner"));
  // The trace's subscription to everything of the owner comes first …
  watcher.subscribe(Pattern("**", owner.id()));
  REQUIRE(waitFor([&] { return watcher.get(owner.id(), "BlindPosition").has_value(); }, kDeadline));

  // … a plain callback registered now, with a fresh subscription, never
  // hears of the value (this is what the runner did): the kernel's view.
  std::atomic<int> plain{0};
  watcher.onChange(Pattern::exact(owner.id(), "BlindPosition"), [&](const Tuple&) { ++plain; });
  watcher.subscribe(Pattern::exact(owner.id(), "BlindPosition"));

  // The watch hands on the cached value at once, and then each change once.
  std::mutex mu;
  std::vector<std::string> seen;
  scenario::TupleWatch watch(watcher, owner.id(), "BlindPosition", [&](const Tuple* t) {
    std::lock_guard lock(mu);
    seen.push_back(t ? t->data : "<deleted>");
  });
  {
    std::lock_guard lock(mu);
    REQUIRE(seen == std::vector<std::string>{"0"});
  }
  owner.set("BlindPosition", "100");
  REQUIRE(waitFor(
      [&] {
        std::lock_guard lock(mu);
        return seen.size() >= 2;
      },
      kDeadline));
  owner.erase("BlindPosition");
  REQUIRE(waitFor(
      [&] {
        std::lock_guard lock(mu);
        return seen.size() >= 3;
      },
      kDeadline));
  std::lock_guard lock(mu);
  CHECK(seen == std::vector<std::string>{"0", "100", "<deleted>"});
  CHECK(plain == 1);  // only the change after it registered
}
