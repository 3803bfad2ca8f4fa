// A publisher restarted with the same id (issue 9): a `peis node` process
// killed with SIGKILL and started again numbers its values from 1 again. The
// Component following it through mi-<input> must run again on the new
// life's first values, not once their seqnos pass those of the old life.
// The test waits for conditions with generous deadlines and asserts no timing.
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <memory>
#include <string>
#include <vector>

#include "peis/component.h"
#include "peis/kernel.h"
#include "support/process.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using peis::PeisId;
using peis::test::cliArgs;
using peis::test::Process;
using peis::test::uniqueEcology;
using peis::test::waitFor;

namespace {

constexpr auto kDeadline = std::chrono::milliseconds(20s);

bool reaches(const peis::Kernel& k, PeisId id) {
  for (const auto& peer : k.peers()) {
    if (peer.id == id) return true;
  }
  return false;
}

}  // namespace

TEST_CASE("a component's input follows a publisher restarted with the same id at once",
          "[fault][restart]") {
  const auto ecology = uniqueEcology("restart");
  const PeisId nodeId = 1'000'000 + static_cast<PeisId>(getpid() % 1'000'000);
  const std::vector<std::string> nodeArgs = {"node",        "--peis-id", std::to_string(nodeId),
                                             "--peis-name", "sensor",    "--peis-liveness-ms",
                                             "1000"};
  auto node = std::make_unique<Process>(cliArgs(ecology, nodeArgs));
  peis::Options followerOptions;
  followerOptions.ecology = ecology;
  followerOptions.name = "follower";
  peis::Kernel k(followerOptions);
  REQUIRE(waitFor([&] { return reaches(k, nodeId); }, kDeadline));

  // The sensor's old life, long enough that its seqnos are far ahead: a 10 Hz
  // sensor that ran for 50 s.
  for (int n = 1; n <= 500; ++n) k.set(nodeId, "tick", "old-" + std::to_string(n));

  peis::Component component(k, "follower");
  component.input("tick", 1000ms);
  k.setMeta("mi-tick", nodeId, "tick");
  component.start();

  // From now on the sensor publishes at 10 Hz (its values are written by this
  // PEIS; the node owns and numbers them).
  std::atomic<int> life{1};
  std::atomic<int> count{0};
  const auto ticker = k.every(100ms, [&] {
    k.setAsync(nodeId, "tick",
               "life" + std::to_string(life.load()) + "-" + std::to_string(++count));
  });
  auto inputFrom = [&](const std::string& prefix) {
    const auto value = component.inputValue("tick");
    return component.status() == peis::ComponentStatus::Running && value &&
           value->data.rfind(prefix, 0) == 0;
  };
  REQUIRE(waitFor([&] { return inputFrom("life1-"); }, kDeadline));
  const auto oldSeqno = component.inputValue("tick")->seqno;
  REQUIRE(oldSeqno > 500);

  node->kill(SIGKILL);
  REQUIRE(node->wait(kDeadline).has_value());
  REQUIRE(waitFor([&] { return component.status() == peis::ComponentStatus::Waiting; }, kDeadline));

  life = 2;
  node = std::make_unique<Process>(cliArgs(ecology, nodeArgs));
  const bool back = waitFor([&] { return inputFrom("life2-"); }, kDeadline);
  k.cancelTimer(ticker);
  INFO(node->describe());
  REQUIRE(back);
  // Running again on values of the new life whose seqnos are still far below
  // the old life's: the new incarnation was accepted at once.
  CHECK(component.inputValue("tick")->seqno < oldSeqno);
}
