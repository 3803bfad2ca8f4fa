// Discovery: UDP beacons, their back-off and suppression, the PEIS heard;
// see discovery.h.
#include "net/discovery.h"

#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>

#include <algorithm>
#include <memory>

#include "log.h"
#include "net/overlay.h"
#include "peis/error.h"

namespace peis::net {
namespace asio = boost::asio;
using asio::ip::udp;

namespace {

constexpr int kMaxBeaconBackoff = 8;      // beacon period at most 8x the configured one
constexpr std::size_t kBeaconQuorum = 3;  // beacons heard that make a stable PEIS skip its own
constexpr int kQuietPeriods = 4;          // a PEIS unheard for this many periods is forgotten

std::vector<asio::ip::address_v4> broadcastAddresses(DiscoveryScope scope) {
  std::vector<asio::ip::address_v4> result{asio::ip::make_address_v4("127.255.255.255")};
  if (scope != DiscoveryScope::Lan) return result;
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return result;
  for (auto* it = list; it; it = it->ifa_next) {
    if (!it->ifa_addr || it->ifa_addr->sa_family != AF_INET) continue;
    if ((it->ifa_flags & IFF_LOOPBACK) || !(it->ifa_flags & IFF_BROADCAST) ||
        !(it->ifa_flags & IFF_UP) || !it->ifa_broadaddr) {
      continue;
    }
    const auto* sin = reinterpret_cast<const sockaddr_in*>(it->ifa_broadaddr);
    result.emplace_back(ntohl(sin->sin_addr.s_addr));
  }
  freeifaddrs(list);
  return result;
}

}  // namespace

DiscoveryScope parseDiscoveryScope(std::string_view text) {
  if (text == "off") return DiscoveryScope::Off;
  if (text == "loopback") return DiscoveryScope::Loopback;
  if (text == "lan") return DiscoveryScope::Lan;
  throw Error(ErrorCode::InvalidArgument,
              "discovery scope '" + std::string(text) + "' is not off, loopback or lan");
}

Discovery::Discovery(asio::io_context& io, Config config, Counters& counters, PeisId self,
                     std::uint64_t incarnation, Events events)
    : io_(io),
      config_(std::move(config)),
      counters_(counters),
      self_(self),
      incarnation_(incarnation),
      events_(std::move(events)),
      udp_(io),
      timer_(io) {}

void Discovery::start(std::uint16_t tcpPort) {
  tcpPort_ = tcpPort;
  if (config_.scope == DiscoveryScope::Off) return;
  boost::system::error_code ec;
  udp_.open(udp::v4(), ec);
  if (!ec) udp_.set_option(udp::socket::reuse_address(true), ec);
  if (!ec) udp_.set_option(asio::socket_base::broadcast(true), ec);
  if (!ec) udp_.bind(udp::endpoint(udp::v4(), config_.port), ec);
  if (ec) {
    log::warn(self_, "discovery off: cannot bind UDP port " + std::to_string(config_.port) + ": " +
                         ec.message());
    udp_.close(ec);
    return;
  }
  receive();
  // The configured period until the membership has been stable for a
  // period (from 0, the back-off below would stay at 0: a PEIS alone would
  // beacon without pause).
  interval_ = config_.beaconPeriod;
  membershipChanged_ = SteadyClock::now();
  beaconLoop();
}

void Discovery::stop() {
  stopped_ = true;
  boost::system::error_code ec;
  udp_.close(ec);
  timer_.cancel();
}

void Discovery::setSelf(PeisId self) {
  self_ = self;
  if (udp_.is_open()) {
    send(udp::endpoint(asio::ip::make_address_v4("127.255.255.255"), config_.port), true);
  }
}

std::vector<PeisId> Discovery::sortedIds() const {
  std::vector<PeisId> ids{self_};
  for (const auto& [id, peer] : peers_) {
    if (!peer.tool) ids.push_back(id);
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

const Discovery::Peer* Discovery::peer(PeisId id) const {
  const auto it = peers_.find(id);
  return it == peers_.end() ? nullptr : &it->second;
}

void Discovery::beaconLoop() {
  const auto now = SteadyClock::now();
  // Suppression: while the membership is stable, a PEIS that heard the
  // beacons of kBeaconQuorum others since its own last one skips this one.
  // Newcomers and healed partitions are still found through those others;
  // each PEIS then receives a few beacons a period instead of one from every
  // PEIS. After a change nobody skips, so a newcomer hears everybody.
  const bool stable = now - membershipChanged_ >= interval_;
  if (!stable || heardFrom_.size() < kBeaconQuorum) {
    for (const auto& address : broadcastAddresses(config_.scope)) {
      send(udp::endpoint(address, config_.port), true);
    }
  } else {
    ++counters_.beaconsSuppressed;
  }
  heardFrom_.clear();
  // Forget PEIS that went quiet. One still reachable by route is alive even
  // if its beacons are late (a loaded host): forgetting it would reshape the
  // overlay for nothing.
  for (auto it = peers_.begin(); it != peers_.end();) {
    const bool quiet = now - it->second.lastSeen > config_.beaconPeriod * kQuietPeriods;
    if (quiet && !(events_.reachable && events_.reachable(it->first))) {
      const bool tool = it->second.tool;
      it = peers_.erase(it);
      if (!tool) membershipChanged(now);
    } else {
      ++it;
    }
  }
  if (events_.onPeriod) events_.onPeriod();
  // While the membership is stable the period doubles, up to
  // kMaxBeaconBackoff times the configured one: N PEIS on a quiet network
  // then cost each other N/8 beacons a second instead of N. A change
  // (below, and in onBeacon) brings the configured period back.
  if (now - membershipChanged_ >= interval_) {
    interval_ = std::min(interval_ * 2, config_.beaconPeriod * kMaxBeaconBackoff);
  } else {
    interval_ = config_.beaconPeriod;
  }
  armBeacon(now + interval_);
}

void Discovery::armBeacon(SteadyClock::time_point at) {
  due_ = at;
  timer_.expires_at(at);
  timer_.async_wait([this](const boost::system::error_code& ec) {
    if (!ec && !stopped_) beaconLoop();
  });
}

// The membership changed: beacon at the configured period again.
void Discovery::membershipChanged(SteadyClock::time_point now) {
  membershipChanged_ = now;
  if (events_.onMembershipChanged) events_.onMembershipChanged();
  if (interval_ == config_.beaconPeriod) return;
  interval_ = config_.beaconPeriod;
  if (udp_.is_open() && due_ > now + interval_) armBeacon(now + interval_);
}

void Discovery::send(const udp::endpoint& to, bool wantsAnswer) {
  Beacon beacon{config_.ecology, self_,        incarnation_,   tcpPort_,
                wantsAnswer,     config_.tool, config_.secured};
  auto payload = std::make_shared<std::string>(encodeBeacon(beacon));
  udp_.async_send_to(asio::buffer(*payload), to,
                     [payload](const boost::system::error_code&, std::size_t) {});
}

void Discovery::receive() {
  udp_.async_receive_from(asio::buffer(buffer_), from_,
                          [this](const boost::system::error_code& ec, std::size_t n) {
                            if (stopped_ || ec == asio::error::operation_aborted) return;
                            if (!ec) {
                              auto beacon = decodeBeacon(std::string_view(buffer_.data(), n));
                              if (beacon) {
                                onBeacon(*beacon, from_);
                              } else {
                                ++counters_.malformedBeacons;
                              }
                            }
                            receive();
                          });
}

void Discovery::onBeacon(const Beacon& beacon, const udp::endpoint& from) {
  // Another ecology, or an open and a secured one of one name: never linked.
  if (beacon.ecology != config_.ecology || beacon.secured != config_.secured) return;
  if (beacon.id == self_) {
    if (beacon.incarnation != incarnation_) {
      ++counters_.idCollisions;
      if (events_.onCollision) events_.onCollision(beacon.incarnation);
    }
    return;
  }
  if (beacon.tool) return onToolBeacon(beacon, from);
  if (beacon.wantsAnswer && heardFrom_.size() < kBeaconQuorum &&
      std::find(heardFrom_.begin(), heardFrom_.end(), beacon.id) == heardFrom_.end()) {
    heardFrom_.push_back(beacon.id);  // distinct PEIS: one heard twice is one
  }
  auto [it, isNew] = peers_.try_emplace(beacon.id);
  isNew = isNew || it->second.incarnation != beacon.incarnation;
  it->second = Peer{from.address(), beacon.port, beacon.incarnation, SteadyClock::now()};
  if (!isNew) return;
  membershipChanged(SteadyClock::now());
  // Only a PEIS the newcomer should link with answers at once (its fingers,
  // and those whose finger it is): the newcomer learns its overlay
  // neighbours now, the others from their next beacon, which the change
  // brings within a beacon period. N answers to each of N joining PEIS were
  // most of the beacon traffic of a join storm.
  if (beacon.wantsAnswer && !config_.tool && overlayWantsSorted(sortedIds(), self_, beacon.id)) {
    send(from, false);
  }
  if (events_.onNewPeer) events_.onNewPeer(beacon.id);
}

// A tool PEIS is remembered (its address, should it be looked up) and
// answered if it would link with us, as if it joined the overlay; it changes
// nothing else. A tool ignores other tools.
void Discovery::onToolBeacon(const Beacon& beacon, const udp::endpoint& from) {
  if (config_.tool) return;
  auto [it, isNew] = peers_.try_emplace(beacon.id);
  isNew = isNew || it->second.incarnation != beacon.incarnation;
  it->second = Peer{from.address(), beacon.port, beacon.incarnation, SteadyClock::now(), true};
  if (!isNew || !beacon.wantsAnswer) return;
  auto ids = sortedIds();
  ids.insert(std::lower_bound(ids.begin(), ids.end(), beacon.id), beacon.id);
  if (overlayWantsSorted(ids, self_, beacon.id)) send(from, false);
}

}  // namespace peis::net
