// Network: the P2P layer of one PEIS. It discovers other PEIS of the same
// ecology (Discovery), keeps TCP links to some of them (Link, the handshake,
// pings and liveness, the link policy), keeps a distance-vector routing table
// so every PEIS reaches every other one over several hops (RoutingTable), and
// delivers and forwards routed frames. It knows frames, not what tuples mean.
// Everything runs on the kernel's io_context thread; no method may be called
// from another thread. network.cpp is the glue between those parts.
#pragma once

#include <boost/asio/io_context.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "net/counters.h"
#include "net/discovery.h"
#include "net/wire.h"
#include "peis/types.h"

namespace peis::security {
struct Credentials;
struct Identity;
}  // namespace peis::security

namespace peis::net {

class Link;

struct NetworkConfig {
  std::string ecology = "default";
  std::string name;
  std::uint16_t port = 0;            // 0: any free port
  std::vector<std::string> connect;  // HOST:PORT links kept up
  DiscoveryScope discovery = DiscoveryScope::Lan;
  std::uint16_t discoveryPort = 7700;  // UDP port of the beacons
  std::chrono::milliseconds beaconPeriod{1000};
  std::chrono::milliseconds pingPeriod{500};
  std::chrono::milliseconds deadAfter{2000};  // silence after which a link is dead
  std::size_t maxDataBytes = kDefaultMaxDataBytes;
  // A link's backlog above which it is congested: what waits for it stays in
  // the outbox (where updates coalesce) until it has drained to half.
  std::size_t coalesceAboveBytes = 4u << 20;
  // A link congested for this long without taking a byte is closed; so is
  // one whose backlog passes maxBacklogBytes (frames relayed for others and
  // link messages do not wait in the outbox).
  std::chrono::milliseconds stalledAfter{2000};
  std::size_t maxBacklogBytes = 64u << 20;
  int maxMalformedFrames = 8;  // then the peer is disconnected
  // Limits against misbehaving peers (Options::limits, docs/security.md).
  std::chrono::milliseconds handshakeTimeout{5000};
  std::size_t maxConnections = 256;
  std::size_t maxHandshakesPerHost = 16;
  std::size_t maxRoutes = 4096;
  std::size_t maxHeldBytes = 4u << 20;
  // How long after start this PEIS gives its id up to an earlier holder.
  std::chrono::milliseconds idClaimWindow{10000};
  // How long frames of a PEIS whose route changed still come the old way.
  std::chrono::milliseconds relayGrace{2000};
  // A secured ecology's credentials (docs/security.md): links are then
  // authenticated and encrypted, routes, names and ids checked against the
  // identities PEIS prove. Null: an open ecology.
  std::shared_ptr<const security::Credentials> credentials;
  // A short-lived tool PEIS (the `peis` command): marked as such in its
  // Hello, beacons and route; other PEIS leave it out of their overlay, and
  // it relays for nobody (docs/protocol.md §6, §8).
  bool tool = false;
};

struct PeerInfo {
  PeisId id = 0;
  std::string name;
  std::uint64_t incarnation = 0;
  int hops = 0;        // 0: this PEIS, 1: a direct link
  PeisId nextHop = 0;  // the linked PEIS the route goes through
  bool tool = false;   // a tool PEIS (NetworkConfig::tool)
};

struct LinkInfo {
  PeisId peer = 0;
  std::string peerName;
  std::string remote;  // address:port
  bool outbound = false;
  std::size_t backlogBytes = 0;
};

class Network {
 public:
  struct Events {
    // Routed messages addressed to this PEIS arrived (those of one socket
    // read together, in order). The handler may move from them; the network
    // decodes later frames into the same messages.
    std::function<void(std::span<wire::RoutedMessage>)> onMessages;
    // A PEIS became reachable, or came back with a new incarnation.
    std::function<void(const PeerInfo&)> onPeerUp;
    // A PEIS is no longer reachable.
    std::function<void(PeisId)> onPeerDown;
    // Routes or links changed (hops, next hops, a link opened or closed);
    // fires after the onPeerUp / onPeerDown events of the same change.
    std::function<void()> onTopology;
    // A link blocked() found congested drained (or closed): send more.
    std::function<void()> onWritable;
    // Another PEIS that started earlier holds our id: pick a new one.
    std::function<PeisId()> repickId;
    // Secured ecologies: why a PEIS that proved this identity is refused
    // (its credentials revoked), or nothing.
    std::function<std::optional<std::string>(const security::Identity&)> refuseIdentity;
  };

  Network(boost::asio::io_context& io, NetworkConfig config, PeisId self, std::uint64_t incarnation,
          Events events);
  ~Network();
  Network(const Network&) = delete;
  Network& operator=(const Network&) = delete;

  // Binds the listener and the discovery socket; throws Error(InvalidArgument)
  // when the port is taken.
  void start();
  // Leaves the ecology: tells every linked PEIS (a Leave, passed on to the
  // whole ecology), closes each link once what it has queued is written,
  // and stops every timer. `closed` runs (on this thread) once no link is
  // left, at once if there is none.
  void stop(std::function<void()> closed = {});

  // Routes a message (envelope source is filled in). False when there is no
  // route to the destination (counted).
  bool send(wire::RoutedMessage message);
  // True while the link to `destination`'s next hop has more than
  // coalesceAboveBytes queued (the link is congested): what waits for it
  // should wait. Events::onWritable fires once that link has drained to
  // half of it, or closed.
  bool blocked(PeisId destination);
  // Closes the link to `destination`'s next hop: that peer reads too slowly
  // (counted in slowPeersDisconnected).
  void cutOff(PeisId destination, const std::string& reason);
  // Sends a tuple update encoded straight from the stored tuple (whose data,
  // when big, is written from the tuple itself: the link keeps it alive).
  bool sendUpdate(PeisId destination, std::uint64_t ownerIncarnation,
                  const std::shared_ptr<const Tuple>& tuple);
  // Sends `count` whole routed frames for `destination`, already encoded
  // with this PEIS as their source (copied into the link's write buffer).
  bool sendFrames(PeisId destination, std::string_view frames, std::uint32_t count);

  // The link of `destination`'s next hop (null when none, and on a secured
  // link when the next hop is a relay: those frames carry SourceTags), for
  // direct sends from other threads (Link::sendNow, which seals on a
  // secured link); valid until the next onTopology.
  std::shared_ptr<Link> linkTowards(PeisId destination) const;
  // The backlog above which a link counts as congested (coalesceAboveBytes).
  std::size_t congestedAboveBytes() const;

  bool reachable(PeisId id) const;
  std::vector<PeerInfo> peers() const;
  std::vector<LinkInfo> links() const;
  const Counters& counters() const;
  // Secured ecologies: the identity PEIS `id` proved (directly or passed on
  // with its route); null when unknown or in an open ecology.
  const security::Identity* identityOf(PeisId id) const;
  // Closes the links to PEIS whose identity refuseIdentity now refuses (the
  // policy changed); returns how many.
  std::size_t recheckIdentities();
  std::uint16_t port() const;
  PeisId self() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::net
