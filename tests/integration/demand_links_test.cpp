// Demand links (docs/protocol.md §6): an owner streaming big tuples to a
// subscriber that the overlay reaches only through a relay dials it directly,
// and the relay stops carrying the flow. Four in-process kernels found by
// discovery on loopback, with ids picked so that the overlay does not link
// the owner and the subscriber.
#include <atomic>
#include <catch2/catch.hpp>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "net/overlay.h"
#include "peis/kernel.h"
#include "support/integration.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using peis::PeisId;
using peis::test::kDeadline;
using peis::test::kernelOptions;
using peis::test::peerOf;
using peis::test::peersText;
using peis::test::StateReport;
using peis::test::uniqueEcology;

namespace {

peis::Options withId(peis::Options o, PeisId id) {
  o.id = id;
  return o;
}

// A value of `bytes` whose first 8 bytes say its number.
std::string imageFor(std::uint64_t n, std::size_t bytes) {
  std::string data(bytes, static_cast<char>('a' + n % 26));
  std::memcpy(data.data(), &n, sizeof n);
  return data;
}

std::uint64_t numberOf(const std::string& data) {
  std::uint64_t n = 0;
  if (data.size() >= sizeof n) std::memcpy(&n, data.data(), sizeof n);
  return n;
}

}  // namespace

TEST_CASE("a heavy flow through a relay gets a demand link and leaves the relay alone",
          "[integration][demand]") {
  // Owner 1000 and subscriber 1000 + 2^20 + 5 are no fingers of each other:
  // 1000 + 2^20 + 1 is nearer in the owner's interval [2^20, 2^21), and 990
  // is nearer in the subscriber's [2^30, 2^31).
  constexpr PeisId kOwner = 1000, kSubscriber = 1000 + (1 << 20) + 5;
  constexpr PeisId kRelay1 = 1000 + (1 << 20) + 1, kRelay2 = 990;
  const std::vector<PeisId> ids{kRelay2, kOwner, kRelay1, kSubscriber};
  REQUIRE_FALSE(peis::net::overlayWants(ids, kOwner, kSubscriber));

  const auto ecology = uniqueEcology("demand");
  peis::Kernel relay1(withId(kernelOptions(ecology, "relay1"), kRelay1));
  peis::Kernel relay2(withId(kernelOptions(ecology, "relay2"), kRelay2));
  peis::Kernel owner(withId(kernelOptions(ecology, "owner"), kOwner));
  peis::Kernel subscriber(withId(kernelOptions(ecology, "subscriber"), kSubscriber));
  auto relayed = [&] {
    return relay1.networkStats().bytesRelayed + relay2.networkStats().bytesRelayed;
  };
  StateReport report([&] {
    return "owner sees: " + peersText(owner) + "\nsubscriber sees: " + peersText(subscriber) +
           "\nrelayed: " + std::to_string(relayed()) +
           " bytes, demand dials: " + std::to_string(owner.networkStats().demandDials) + " + " +
           std::to_string(subscriber.networkStats().demandDials);
  });

  // The overlay settles: every PEIS known, owner and subscriber two hops apart
  // (a link dialled while the PEIS joined is pruned).
  REQUIRE_WAIT(
      [&] {
        const auto toSubscriber = peerOf(owner, kSubscriber);
        const auto toOwner = peerOf(subscriber, kOwner);
        return owner.peers().size() == 4 && toSubscriber && toSubscriber->hops == 2 && toOwner &&
               toOwner->hops == 2;
      },
      30s);

  constexpr std::size_t kImageBytes = 256 * 1024;
  std::atomic<std::uint64_t> last{0}, received{0}, backwards{0};
  subscriber.onChange(peis::Pattern::exact(kOwner, "image"), [&](const peis::Tuple& t) {
    const auto n = numberOf(t.data);
    if (n <= last || t.data != imageFor(n, kImageBytes)) ++backwards;
    last = n;
    ++received;
  });
  subscriber.subscribe(peis::Pattern::exact(kOwner, "image"));

  // The owner streams images as fast as its subscriber takes them (a writer
  // waits, bounded, for a lagging outbox): far more than 1 MiB a second.
  std::atomic<bool> stop{false};
  std::thread camera([&] {
    for (std::uint64_t n = 1; !stop; ++n) owner.set("image", imageFor(n, kImageBytes));
  });
  struct StopCamera {
    std::atomic<bool>& stop;
    std::thread& camera;
    ~StopCamera() {
      stop = true;
      if (camera.joinable()) camera.join();
    }
  } stopCamera{stop, camera};

  REQUIRE_WAIT([&] { return received > 0; }, kDeadline);
  // The flow is heavy: owner or subscriber dials the other.
  REQUIRE_WAIT(
      [&] {
        const auto toSubscriber = peerOf(owner, kSubscriber);
        const auto toOwner = peerOf(subscriber, kOwner);
        return toSubscriber && toSubscriber->hops == 1 && toOwner && toOwner->hops == 1;
      },
      kDeadline);
  CHECK(owner.networkStats().demandDials + subscriber.networkStats().demandDials >= 1);

  // The relays stop carrying it: while the subscriber gets 20 more images
  // (5 MiB), the relays forward less than one image's bytes.
  std::uint64_t relayedBefore = relayed(), receivedBefore = received;
  REQUIRE_WAIT(
      [&] {
        if (received < receivedBefore + 20) return false;
        const auto now = relayed();
        const bool quiet = now - relayedBefore < kImageBytes;
        relayedBefore = now;
        receivedBefore = received;
        return quiet;
      },
      kDeadline);
  // The link carrying the flow is kept while it is busy (the overlay does
  // not want it: pruning looks at it 2 s after it came up), and nothing
  // came out of order.
  const auto dials = owner.networkStats().demandDials + subscriber.networkStats().demandDials;
  const std::uint64_t streamed = received;
  REQUIRE_WAIT([&] { return received >= streamed + 400; }, kDeadline);  // 100 MiB more
  CHECK(peerOf(owner, kSubscriber)->hops == 1);
  CHECK(owner.networkStats().demandDials + subscriber.networkStats().demandDials == dials);
  CHECK(backwards == 0);
  CHECK(owner.networkStats().slowPeersDisconnected == 0);
  CHECK(relay1.networkStats().slowPeersDisconnected + relay2.networkStats().slowPeersDisconnected ==
        0);

  // Once the flow has stopped for a while, the owner (the lower id) prunes
  // the link as the overlay would.
  stop = true;
  camera.join();
  REQUIRE_WAIT(
      [&] {
        const auto toSubscriber = peerOf(owner, kSubscriber);
        return toSubscriber && toSubscriber->hops == 2;
      },
      40s);
}
