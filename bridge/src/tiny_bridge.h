// The tinybridge: a full PEIS on the tiny nodes' radio that makes each tiny
// node an ordinary PEIS of the ecology (tiny-peis-kernel.txt section IV).
//
//   - Every tiny node heard on the radio gets a proxy PEIS with the node's
//     own id, holding the node's tuples under string keys (the key registry
//     maps sub-key indexes to names). The bridge keeps a radio subscription
//     to every key of every node, so the proxy follows the node.
//   - A full PEIS's set of a tiny node's tuple reaches the proxy, whose
//     write gate holds it, sends a WRITE frame to the node (again every
//     writeRetry) and accepts the write only when the node's own tuple
//     frame shows the value: the writer's set returns once the node has it,
//     or fails (Unreachable) when the node did not confirm by writeDeadline.
//   - A tiny node's subscription to a full PEIS's tuple (Lamp -> LightValue
//     of PEIS 6890) is served by the node's proxy: it subscribes in the
//     ecology and sends every change as a tiny tuple frame to the node, and
//     the current values at each renewal (so losses heal as between nodes).
//   - A node not heard for node-timeout is gone: its proxy leaves.
//
// The bridge's own PEIS publishes tinybridge.nodes, tinybridge.link and
// tinybridge.keys.<name> = index for every registry entry.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "peis/kernel.h"
#include "peis/options.h"
#include "tiny_timing.h"

namespace peis::bridge {

struct BridgeConfig {
  Options peis;                   // the bridge's own PEIS; proxies share its ecology
  std::string link;               // radio link, see openRadioLink()
  std::string registryPath;       // SQLite file of the key registry
  std::string seedPath;           // YAML seed of the registry ("" = none)
  std::uint16_t tinyId = 0xFFFE;  // the bridge's node id on the radio
  // The tiny protocol's timings (tiny_timing.h) unless told otherwise.
  std::chrono::milliseconds nodeTimeout{TINY_NODE_TIMEOUT_MS};
  std::chrono::milliseconds writeRetry{TINY_WRITE_RETRY_MS};
  std::chrono::milliseconds writeDeadline{TINY_WRITE_DEADLINE_MS};
  // A secured radio (docs/security.md): the YAML file of the radio keys
  // ("" = an open radio). The bridge then vouches for the nodes it holds a
  // key of, and for no other.
  std::string radioKeysPath;
  // On an open radio: proxies for nodes not named in the seed's `nodes:`,
  // at most (a made-up node id costs a PEIS each).
  std::size_t maxUnregisteredNodes = 16;
};

// Counters (tinybridge.stats shows them too).
struct BridgeStats {
  std::uint64_t framesIn = 0, framesOut = 0, framesDropped = 0;  // decoder drops
  std::uint64_t tuplesMirrored = 0, tuplesStale = 0;             // node -> proxy
  std::uint64_t tuplesForwarded = 0;                             // full PEIS -> tiny subscriber
  std::uint64_t forwardUnmappable = 0;  // owner id over 65534, unknown key part, too large
  std::uint64_t writesSent = 0, writesConfirmed = 0, writesFailed = 0, writesRefused = 0;
  std::uint64_t nodesJoined = 0, nodesLeft = 0, servedSubscriptions = 0, keysAdded = 0;
  // Limits and the secured radio (docs/security.md): nodes given no proxy
  // (over --max-unregistered-nodes, not vouched for, or an id a full PEIS
  // holds), frames refused (unsecured, unknown sender, bad MAC, replayed),
  // a node's tuple frames naming another owner, writes too long to seal.
  std::uint64_t nodesRefused = 0, framesRefused = 0, tuplesForged = 0;
};

class TinyBridge {
 public:
  // Opens the registry (applying the seed), the radio link and the bridge's
  // PEIS. Throws Error: InvalidConfig (registry, seed), InvalidArgument
  // (link spec), Unreachable (medium).
  explicit TinyBridge(BridgeConfig config);
  ~TinyBridge();
  TinyBridge(const TinyBridge&) = delete;
  TinyBridge& operator=(const TinyBridge&) = delete;

  Kernel& kernel();
  // Runs the radio side on the calling thread until stop() or the bridge
  // PEIS is told to quit; returns why it stopped.
  std::string run();
  // From any thread (or a signal handler: it only sets a flag).
  void stop();
  BridgeStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::bridge
