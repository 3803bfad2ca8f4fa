// Discovery: the UDP beacons of one PEIS (docs/protocol.md §6). It
// broadcasts a beacon every beacon period (backing off up to 8x while the
// PEIS it knows do not change, and skipping its own while it hears enough
// others), answers newcomers it should link with, and remembers the PEIS of
// its ecology it heard (address, TCP port, incarnation) until they go quiet.
// Whom to dial and which links to prune is decided by the Network from what
// Discovery knows (net/link_policy.h). A tool PEIS (the `peis` command) is
// heard but left out of the overlay and of the membership: its coming and
// going changes no other PEIS's links or beacon period. Kernel thread only.
#pragma once

#include <array>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/udp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "net/beacon.h"
#include "net/counters.h"

namespace peis::net {

enum class DiscoveryScope { Off, Loopback, Lan };

class Discovery {
 public:
  using SteadyClock = std::chrono::steady_clock;
  struct Config {
    std::string ecology;
    DiscoveryScope scope = DiscoveryScope::Lan;
    std::uint16_t port = 7700;  // UDP port of the beacons
    std::chrono::milliseconds beaconPeriod{1000};
    bool tool = false;     // this PEIS is a tool (its beacons say so)
    bool secured = false;  // of a secured ecology (its beacons say so)
  };
  struct Peer {
    boost::asio::ip::address address;
    std::uint16_t port = 0;  // TCP
    std::uint64_t incarnation = 0;
    SteadyClock::time_point lastSeen;
    bool tool = false;  // a tool PEIS: outside the overlay
  };
  struct Events {
    // A PEIS not known before, or known with another incarnation.
    std::function<void(PeisId)> onNewPeer;
    // The set of known PEIS changed (a newcomer, a new incarnation, one
    // forgotten).
    std::function<void()> onMembershipChanged;
    // A beacon carries our id with another incarnation (docs/protocol.md §7).
    std::function<void(std::uint64_t otherIncarnation)> onCollision;
    // Every beacon period, after the beacon.
    std::function<void()> onPeriod;
    // Whether a PEIS is reachable by route (a quiet one is then kept).
    std::function<bool(PeisId)> reachable;
  };

  Discovery(boost::asio::io_context& io, Config config, Counters& counters, PeisId self,
            std::uint64_t incarnation, Events events);

  // Binds the UDP port and starts beaconing for TCP port `tcpPort`. Without
  // the port (taken without address reuse) it warns and stays off.
  void start(std::uint16_t tcpPort);
  void stop();
  bool running() const { return udp_.is_open(); }
  // This PEIS re-picked its id: announce the new one (a beacon asking for
  // answers).
  void setSelf(PeisId self);

  // The known PEIS but tools, and this one, ascending (the overlay's input).
  std::vector<PeisId> sortedIds() const;
  const Peer* peer(PeisId id) const;
  bool knows(PeisId id) const { return peers_.count(id) != 0; }
  SteadyClock::time_point membershipChangedAt() const { return membershipChanged_; }

 private:
  void beaconLoop();
  void armBeacon(SteadyClock::time_point at);
  void membershipChanged(SteadyClock::time_point now);
  void send(const boost::asio::ip::udp::endpoint& to, bool wantsAnswer);
  void receive();
  void onBeacon(const Beacon& beacon, const boost::asio::ip::udp::endpoint& from);
  void onToolBeacon(const Beacon& beacon, const boost::asio::ip::udp::endpoint& from);

  boost::asio::io_context& io_;
  Config config_;
  Counters& counters_;
  PeisId self_;
  std::uint64_t incarnation_;
  Events events_;
  std::uint16_t tcpPort_ = 0;
  bool stopped_ = false;
  boost::asio::ip::udp::socket udp_;
  boost::asio::ip::udp::endpoint from_;
  std::array<char, 512> buffer_{};
  boost::asio::steady_timer timer_;
  std::map<PeisId, Peer> peers_;
  SteadyClock::time_point membershipChanged_;
  std::chrono::milliseconds interval_{0};  // the current beacon period
  SteadyClock::time_point due_;
  // Distinct PEIS whose broadcast beacons we heard since our last one (up to
  // the quorum).
  std::vector<PeisId> heardFrom_;
};

DiscoveryScope parseDiscoveryScope(std::string_view text);

}  // namespace peis::net
