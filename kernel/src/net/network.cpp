// Network: the glue of the network layer (see network.h). It owns the
// listener and the links, carries out the handshake's verdicts, feeds the
// routing table with links and adverts and sends what it says, checks and
// forwards routed frames (holding those whose source has no route yet), runs
// pings and liveness, and dials and prunes links as the link policy says.
// The bytes are in docs/protocol.md.
#include "net/network.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <algorithm>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <deque>
#include <set>

#include "log.h"
#include "net/handshake.h"
#include "net/link.h"
#include "net/link_policy.h"
#include "net/routing_table.h"
#include "peis/error.h"
#include "peis/key.h"
#include "peis/options.h"

namespace peis::net {
namespace asio = boost::asio;
using asio::ip::tcp;
using SteadyClock = std::chrono::steady_clock;

namespace {

constexpr std::chrono::milliseconds kAdvertDelay{100};  // adverts at most every 100 ms
constexpr std::chrono::milliseconds kRedialPeriod{1000};
constexpr std::chrono::milliseconds kDialQuiet{15};
constexpr std::chrono::milliseconds kDialMaxDelay{1000};
constexpr std::chrono::milliseconds kRecomputeDelay{20};  // recomputes at most every 20 ms
constexpr std::chrono::seconds kHoldFor{3};  // how long a frame waits for its source's route
constexpr std::size_t kMaxHeldFrames = 1024;
// How many liveness times a silent peer whose host still acknowledges our
// bytes is given (see pingLoop).
constexpr int kSlowPeerGrace = 4;

}  // namespace

class Network::Impl final : public LinkHandler {
 public:
  Impl(asio::io_context& io, NetworkConfig config, PeisId self, std::uint64_t incarnation,
       Events events)
      : self_(self),
        io_(io),
        config_(std::move(config)),
        incarnation_(incarnation),
        events_(std::move(events)),
        table_(tableConfig(config_, self, incarnation)),
        discovery_(io,
                   Discovery::Config{config_.ecology, config_.discovery, config_.discoveryPort,
                                     config_.beaconPeriod, config_.tool},
                   counters_, self, incarnation, discoveryEvents()),
        acceptor_(io),
        pingTimer_(io),
        redialTimer_(io),
        dialTimer_(io),
        acceptRetry_(io),
        pruneTimer_(io),
        holdTimer_(io),
        explicitLinks_(config_.connect.size()) {}

  void start();
  void stop(std::function<void()> closed);
  bool send(wire::RoutedMessage message);
  bool sendUpdate(PeisId destination, std::uint64_t incarnation,
                  const std::shared_ptr<const Tuple>& tuple);
  bool sendFrames(PeisId destination, std::string_view frames, std::uint32_t count);
  std::vector<PeerInfo> peers() const;
  std::vector<LinkInfo> links() const;
  bool blocked(PeisId destination);
  void cutOff(PeisId destination, const std::string& reason);
  bool reachable(PeisId id) const { return table_.contains(id); }
  std::shared_ptr<Link> linkTowards(PeisId destination) const {
    const PeisId next = table_.nextHop(destination);
    return next == 0 ? nullptr : linkTo(next);
  }
  std::size_t congestedAboveBytes() const { return config_.coalesceAboveBytes; }
  std::uint16_t listenPort() const {
    boost::system::error_code ec;
    const auto endpoint = acceptor_.local_endpoint(ec);
    return ec ? 0 : endpoint.port();
  }

  // LinkHandler
  void onFrame(Link& link, std::string_view frame) override;
  // A routed frame whose data is over this PEIS's limit (its whole frame or
  // its first kOversizeHeadBytes): answered, not dropped (protocol.md §2.1).
  // False when it is not one (malformed).
  bool onOversize(Link& link, std::string_view head) override;
  void onReadDone(Link&) override { flushInbox(); }
  void onWritten(Link& link) override;
  void onClosed(Link& link, const std::string& reason) override;

  Counters counters_;
  PeisId self_;

 private:
  std::size_t maxFrameBytes() const { return config_.maxDataBytes + wire::kMaxFrameOverhead; }
  static RoutingTable::Config tableConfig(const NetworkConfig& config, PeisId self,
                                          std::uint64_t incarnation);
  Discovery::Events discoveryEvents();
  // --- links and the handshake
  void accept();
  void dial(const std::string& host, std::uint16_t port, int explicitIndex);
  void addLink(tcp::socket socket, bool outbound, int explicitIndex, PeisId dialTarget = 0);
  void onHello(Link& link, const wire::Hello& hello);
  void onMalformed(Link& link, const std::string& error);
  void collision(std::uint64_t otherIncarnation);
  std::shared_ptr<Link> linkTo(PeisId peer) const;
  Link* findLink(PeisId peer) const;  // linkTo without the reference count
  wire::Hello hello() const;
  void sendLinkMessage(Link& link, const wire::LinkMessage& message);
  void pingLoop();
  void redialLoop();
  // --- routing
  void onRoutes(Link& link, wire::Routes& routes);
  void onLeave(Link& link, const wire::Leave& leave);
  // Sends what the routing table asks for now, and schedules its adverts,
  // recompute and hold deadline.
  void afterTable();
  // Runs the routing table's recompute and reports what changed.
  void recompute();
  void scheduleRecompute();
  void scheduleAdvert();
  void advertise();
  // --- routed frames
  void onRouted(Link& link, std::string_view frame);
  void deliverOrForward(std::string_view frame, wire::RoutedMessage&& message);
  void forwardFrame(std::string_view frame, const wire::Envelope& envelope);
  // `relayedFrom`: the source of a frame this PEIS relays (0: its own).
  bool forward(PeisId destination, std::string frame, PeisId relayedFrom = 0);
  Link* nextHopLink(PeisId destination);  // counts unroutable when none
  void retryHeld();
  void flushInbox();
  // --- dial and prune
  void evaluateDials();
  // Evaluates dials once beacons have been quiet for a moment (bounded), so
  // PEIS starting together do not link to every target they pass through.
  void scheduleDials();
  void pruneLinks();
  // Runs pruneLinks once the membership and the links have been settled for
  // kLinkGrace (not only at the next beacon, which may be 8 s away).
  void schedulePrune();
  void armPrune(SteadyClock::time_point at);

  struct Throttle {
    explicit Throttle(asio::io_context& io) : timer(io) {}
    asio::steady_timer timer;
    bool scheduled = false;
    SteadyClock::time_point last;
  };
  void throttle(Throttle& t, std::chrono::milliseconds interval, void (Impl::*work)());

  asio::io_context& io_;
  NetworkConfig config_;
  std::uint64_t incarnation_;
  Events events_;
  bool stopped_ = false;
  RoutingTable table_;
  Discovery discovery_;
  tcp::acceptor acceptor_;
  asio::steady_timer pingTimer_, redialTimer_, dialTimer_, acceptRetry_, pruneTimer_, holdTimer_;
  std::optional<SteadyClock::time_point> holdArmed_;
  std::function<void()> closed_;  // after stop(): runs once no link is left
  bool pruneArmed_ = false;
  SteadyClock::time_point hostBusyUntil_;  // see pingLoop
  bool dialsPending_ = false;
  SteadyClock::time_point dialsFirstAsked_;
  Throttle recomputeThrottle_{io_}, advertThrottle_{io_};
  std::vector<std::shared_ptr<Link>> links_;
  std::vector<std::weak_ptr<Link>> explicitLinks_;
  std::set<PeisId> dialing_;
  std::uint64_t routesEpoch_ = 1;  // bumped whenever routes, links or adverts change
  std::string decodeError_;
  struct Held {
    std::string frame;
    wire::RoutedMessage message;
    SteadyClock::time_point arrived;
  };
  std::deque<Held> held_;
  // Answers to frames over the data limit (onOversize) for a PEIS with no
  // route yet (its first frames can be faster than its route, as above):
  // sent once it has one, dropped after kHoldFor.
  std::deque<std::pair<wire::RoutedMessage, SteadyClock::time_point>> heldAnswers_;
  // Messages for this PEIS, handed over together once a read is parsed. Two
  // buffers take turns so a stream of reads allocates no new vector.
  std::vector<wire::RoutedMessage> inbox_;
  std::vector<wire::RoutedMessage> spareInbox_;
};

// --- Life cycle ------------------------------------------------------------------

RoutingTable::Config Network::Impl::tableConfig(const NetworkConfig& config, PeisId self,
                                                std::uint64_t incarnation) {
  RoutingTable::Config c;
  c.self = self;
  c.incarnation = incarnation;
  c.name = config.name;
  c.tool = config.tool;
  // A route with only infeasible successors waits at most half a liveness
  // period for the destination's new seqno: a PEIS that is gone leaves
  // every table within one liveness period.
  c.holdFor = std::max(config.deadAfter / 2, std::chrono::milliseconds(50));
  return c;
}

Discovery::Events Network::Impl::discoveryEvents() {
  Discovery::Events e;
  e.onNewPeer = [this](PeisId) { scheduleDials(); };
  e.onMembershipChanged = [this] { schedulePrune(); };
  e.onCollision = [this](std::uint64_t other) { collision(other); };
  e.onPeriod = [this] {
    evaluateDials();
    pruneLinks();
  };
  e.reachable = [this](PeisId id) { return table_.contains(id); };
  return e;
}

void Network::Impl::start() {
  tcp::endpoint endpoint(tcp::v4(), config_.port);
  boost::system::error_code ec;
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw Error(ErrorCode::InvalidArgument,
                "cannot listen on TCP port " + std::to_string(config_.port) + ": " + ec.message());
  }
  accept();
  discovery_.start(listenPort());
  for (std::size_t i = 0; i < config_.connect.size(); ++i) {
    const auto [host, port] = parseHostPort(config_.connect[i]);
    dial(host, port, static_cast<int>(i));
  }
  pingLoop();
  redialLoop();
}

void Network::Impl::stop(std::function<void()> closed) {
  stopped_ = true;
  closed_ = std::move(closed);
  boost::system::error_code ec;
  acceptor_.close(ec);
  discovery_.stop();
  pingTimer_.cancel();
  advertThrottle_.timer.cancel();
  redialTimer_.cancel();
  dialTimer_.cancel();
  recomputeThrottle_.timer.cancel();
  pruneTimer_.cancel();
  acceptRetry_.cancel();
  holdTimer_.cancel();
  // A clean leave: every PEIS forgets this one at once instead of waiting
  // for its routes to time out (the Leave floods, docs/protocol.md §8).
  auto links = links_;
  for (auto& link : links) {
    if (link->established_) {
      sendLinkMessage(*link, wire::Leave{self_, incarnation_});
      link->closeAfterFlush("leaving");
    } else {
      link->close("shutting down");
    }
  }
  if (links_.empty() && closed_) std::exchange(closed_, {})();
}

// --- Links and the handshake ---------------------------------------------------------

wire::Hello Network::Impl::hello() const {
  wire::Hello h;
  h.ecology = config_.ecology;
  h.id = self_;
  h.incarnation = incarnation_;
  h.name = config_.name;
  h.listenPort = listenPort();
  h.capabilities = wire::kCapabilityCoalescing | (config_.tool ? wire::kCapabilityTool : 0);
  return h;
}

void Network::Impl::sendLinkMessage(Link& link, const wire::LinkMessage& message) {
  std::string out;
  wire::encode(message, out);
  link.sendFrame(out);
}

void Network::Impl::accept() {
  acceptor_.async_accept([this](const boost::system::error_code& ec, tcp::socket socket) {
    if (stopped_) return;
    if (!ec) {
      addLink(std::move(socket), false, -1);
      return accept();
    }
    // Out of descriptors or similar: say so once in a while and retry later
    // rather than spinning on the error.
    log::warn(self_, "cannot accept a link: " + ec.message());
    acceptRetry_.expires_after(std::chrono::milliseconds(200));
    acceptRetry_.async_wait([this](const boost::system::error_code& e) {
      if (!e && !stopped_) accept();
    });
  });
}

void Network::Impl::dial(const std::string& host, std::uint16_t port, int explicitIndex) {
  auto resolver = std::make_shared<tcp::resolver>(io_);
  resolver->async_resolve(
      host, std::to_string(port),
      [this, resolver, explicitIndex, host](const boost::system::error_code& ec,
                                            tcp::resolver::results_type results) {
        if (stopped_) return;
        if (ec) {
          log::warn(self_, "cannot resolve " + host + ": " + ec.message());
          return;
        }
        auto socket = std::make_shared<tcp::socket>(io_);
        asio::async_connect(*socket, results,
                            [this, socket, explicitIndex](const boost::system::error_code& ec2,
                                                          const tcp::endpoint&) {
                              if (stopped_ || ec2) return;
                              addLink(std::move(*socket), true, explicitIndex);
                            });
      });
}

void Network::Impl::addLink(tcp::socket socket, bool outbound, int explicitIndex,
                            PeisId dialTarget) {
  auto link = std::make_shared<Link>(*this, counters_, maxFrameBytes(), std::move(socket), outbound,
                                     explicitIndex);
  link->dialTarget_ = dialTarget;
  links_.push_back(link);
  if (explicitIndex >= 0) explicitLinks_[static_cast<std::size_t>(explicitIndex)] = link;
  link->start(hello());
}

void Network::Impl::onClosed(Link& link, const std::string& reason) {
  links_.erase(std::remove_if(links_.begin(), links_.end(),
                              [&](const std::shared_ptr<Link>& l) { return l.get() == &link; }),
               links_.end());
  if (link.dialTarget_ != 0) dialing_.erase(link.dialTarget_);
  if (stopped_) {
    if (links_.empty() && closed_) std::exchange(closed_, {})();
    return;
  }
  if (link.congested_ && events_.onWritable) events_.onWritable();  // its waiting moves on
  if (!link.established_) {
    log::debug(self_, "link " + link.remote_ + " closed before the handshake: " + reason);
    return;
  }
  ++routesEpoch_;  // sources checked on other links may now be judged otherwise
  const PeisId peer = link.peer_.id;
  dialing_.erase(peer);
  log::info(self_,
            "link to PEIS " + std::to_string(peer) + " (" + link.remote_ + ") closed: " + reason);
  if (!linkTo(peer)) table_.linkDown(peer);
  recompute();
}

void Network::Impl::onMalformed(Link& link, const std::string& error) {
  ++counters_.malformedFrames;
  log::warn(self_, "dropped a malformed frame from " + link.remote_ + ": " + error);
  if (++link.malformed_ >= config_.maxMalformedFrames || !link.established_) {
    ++counters_.garbagePeersDisconnected;
    link.close("sent garbage");
  }
}

void Network::Impl::onFrame(Link& link, std::string_view frame) {
  ++counters_.framesIn;
  if (wire::isRoutedFrame(frame)) {
    // Decoded straight into the inbox; onRouted takes it out again unless
    // it is for this PEIS.
    auto& message = inbox_.emplace_back();
    if (!wire::decodeRouted(frame, config_.maxDataBytes, message, decodeError_)) {
      inbox_.pop_back();
      if (onOversize(link, frame)) return;
      return onMalformed(link, decodeError_);
    }
    if (!link.established_) {
      inbox_.pop_back();
      ++counters_.garbagePeersDisconnected;
      return link.close("routed message before the handshake");
    }
    return onRouted(link, frame);
  }
  // The routed messages that came before this link message in the same read
  // go first: a PEIS that answers a write and then leaves must not be seen
  // gone (its Leave, which fails the write) before its answer.
  flushInbox();
  auto result = wire::decode(frame, config_.maxDataBytes);
  if (!result.message) return onMalformed(link, result.error);
  auto& message = std::get<wire::LinkMessage>(*result.message);
  if (auto* hello = std::get_if<wire::Hello>(&message)) return onHello(link, *hello);
  if (!link.established_) {
    ++counters_.garbagePeersDisconnected;
    return link.close("no handshake");
  }
  if (auto* ping = std::get_if<wire::Ping>(&message)) {
    sendLinkMessage(link, wire::Pong{ping->nonce});
  } else if (auto* routes = std::get_if<wire::Routes>(&message)) {
    onRoutes(link, *routes);
  } else if (auto* leave = std::get_if<wire::Leave>(&message)) {
    onLeave(link, *leave);
  } else if (auto* request = std::get_if<wire::SeqnoRequest>(&message)) {
    table_.onSeqnoRequest(link.peer_.id, *request, SteadyClock::now());
    afterTable();
  } else if (auto* taken = std::get_if<wire::IdTaken>(&message)) {
    if (taken->id == self_ && taken->incarnation == incarnation_) collision(0);
  }
}

bool Network::Impl::onOversize(Link& link, std::string_view head) {
  auto oversize = wire::decodeOversize(head, config_.maxDataBytes);
  if (!oversize || !link.established_) return false;
  auto answer = wire::answerOversize(*oversize, self_, config_.maxDataBytes);
  if (answer.envelope.destination == self_) {
    inbox_.push_back(std::move(answer));  // a TupleWithheld in place of the owner's update
  } else if (table_.contains(answer.envelope.destination)) {
    forward(answer.envelope.destination, wire::encodeFrame(answer));
  } else {
    heldAnswers_.emplace_back(std::move(answer), SteadyClock::now());
  }
  return true;
}

void Network::Impl::onHello(Link& link, const wire::Hello& hello) {
  const auto existing = linkTo(hello.id);
  HelloContext context{self_, incarnation_, config_.ecology, link.established_, link.outbound_};
  if (existing) {
    context.existing = &existing->peer_;
    context.existingOutbound = existing->outbound_;
  }
  switch (judgeHello(context, hello)) {
    case HelloVerdict::Ignore:
      ++link.malformed_;
      return;
    case HelloVerdict::WrongVersion:
      return link.close("protocol version " + std::to_string(hello.version) + " is not " +
                        std::to_string(wire::kVersion));
    case HelloVerdict::ForeignEcology:
      ++counters_.foreignEcologyRejected;
      return link.close("peer belongs to ecology '" + hello.ecology + "'");
    case HelloVerdict::Myself:
      return link.close("connected to myself");
    case HelloVerdict::IdMine:
      ++counters_.idCollisions;
      sendLinkMessage(link, wire::IdTaken{hello.id, hello.incarnation});
      return link.closeAfterFlush("id " + std::to_string(self_) + " is mine");
    case HelloVerdict::IdTheirs:
      ++counters_.idCollisions;
      link.close("id collision");
      return collision(hello.incarnation);
    case HelloVerdict::OtherIncarnationLinked:
      ++counters_.idCollisions;
      return link.close("PEIS " + std::to_string(hello.id) +
                        " is already linked with another incarnation");
    case HelloVerdict::Duplicate:
      return link.close("duplicate link to PEIS " + std::to_string(hello.id));
    case HelloVerdict::ReplacesExisting:
      existing->established_ = false;
      existing->close("replaced by a new link");
      break;
    case HelloVerdict::Establish:
      break;
  }
  link.established_ = true;
  ++routesEpoch_;
  link.establishedAt_ = SteadyClock::now();
  if (link.explicitIndex_ < 0) schedulePrune();
  link.peer_ = hello;
  dialing_.erase(hello.id);
  log::info(self_, "linked to PEIS " + std::to_string(hello.id) + " '" + hello.name + "' at " +
                       link.remote_ + (link.outbound_ ? " (dialled)" : " (accepted)"));
  table_.linkUp(hello);
  recompute();
  // The new link gets the whole table now; the others hear of the new route
  // with the next advert.
  if (link.closed()) return;
  auto all = table_.fullAdvert(hello.id);
  if (!all.entries.empty()) sendLinkMessage(link, all);
}

void Network::Impl::collision(std::uint64_t otherIncarnation) {
  if (otherIncarnation != 0 && otherIncarnation > incarnation_) return;  // the other re-picks
  const PeisId old = self_;
  self_ = events_.repickId ? events_.repickId() : old;
  log::warn(old, "id " + std::to_string(old) + " is held by a PEIS that started earlier; now " +
                     std::to_string(self_));
  table_.reset(self_);
  ++routesEpoch_;
  auto links = links_;
  for (auto& l : links) l->close("re-picked my id");
  discovery_.setSelf(self_);
}

std::shared_ptr<Link> Network::Impl::linkTo(PeisId peer) const {
  for (const auto& link : links_) {
    if (link->established_ && link->peer_.id == peer) return link;
  }
  return nullptr;
}

Link* Network::Impl::findLink(PeisId peer) const {
  for (const auto& link : links_) {
    if (link->established_ && link->peer_.id == peer) return link.get();
  }
  return nullptr;
}

void Network::Impl::pingLoop() {
  pingTimer_.expires_after(config_.pingPeriod);
  pingTimer_.async_wait([this](const boost::system::error_code& ec) {
    if (ec || stopped_) return;
    retryHeld();  // ages out frames whose source never became routable
    const auto now = SteadyClock::now();
    // This timer running a whole period late says the host is overloaded:
    // its processes (the peers too) wait for a core. For a while the
    // liveness check then gives peers that are slow rather than gone more
    // time (below).
    if (now - pingTimer_.expiry() > config_.pingPeriod) {
      hostBusyUntil_ = now + config_.deadAfter * kSlowPeerGrace;
    }
    const bool hostBusy = now < hostBusyUntil_;
    auto links = links_;
    for (auto& link : links) {
      // Bytes waiting in the socket are a sign of life too: after this
      // thread was starved (a busy host), the timer can run before the reads.
      // On an overloaded host (a join of hundreds of PEIS on two cores:
      // processes wait seconds for a core), a peer whose host still
      // acknowledges every byte sent to it (our pings) is slow, not gone:
      // closing its link, which is fine, and re-linking would feed the
      // load. It gets kSlowPeerGrace times the liveness time. A peer whose
      // host is gone leaves our bytes unacknowledged, and on a host that is
      // not overloaded a frozen peer is closed, both as before.
      const auto silent = now - link->lastHeard_;
      if (silent > config_.deadAfter && !link->bytesWaiting() &&
          (silent > config_.deadAfter * kSlowPeerGrace || !hostBusy ||
           !link->peerAcknowledgesAll())) {
        link->close(
            "silent for more than " +
            std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(silent).count()) +
            " ms");
        continue;
      }
      // A peer that stopped reading: its link stays congested and takes
      // nothing. It is cut off rather than left to hold its messages.
      if (link->congested_ && link->writeWaiting(now) > config_.stalledAfter) {
        ++counters_.slowPeersDisconnected;
        const auto reason = "took nothing for " + std::to_string(config_.stalledAfter.count()) +
                            " ms with " + std::to_string(link->backlog()) + " bytes queued";
        log::warn(self_, "closing the link to " + link->remote_ + ": " + reason);
        link->close(reason);
        continue;
      }
      // Ping only a link we have heard nothing on for a ping period: the
      // Ping tells the peer we live, its Pong tells us. A link busy in
      // one direction costs one Ping a period, an idle one a single
      // exchange (whichever end asks first), not one from each end.
      // So does one that receives a big frame and sends nothing: the peer
      // sending it hears nothing else, and its own Ping waits behind the frame.
      const bool quiet = now - link->lastHeard_ >= config_.pingPeriod ||
                         (link->midFrame() && now - link->lastSent() >= config_.pingPeriod);
      if (!link->established_ || !quiet) continue;
      sendLinkMessage(*link,
                      wire::Ping{static_cast<std::uint64_t>(now.time_since_epoch().count())});
    }
    pingLoop();
  });
}

void Network::Impl::redialLoop() {
  redialTimer_.expires_after(kRedialPeriod);
  redialTimer_.async_wait([this](const boost::system::error_code& ec) {
    if (ec || stopped_) return;
    for (std::size_t i = 0; i < config_.connect.size(); ++i) {
      if (!explicitLinks_[i].expired()) continue;
      const auto [host, port] = parseHostPort(config_.connect[i]);
      dial(host, port, static_cast<int>(i));
    }
    redialLoop();
  });
}

// --- Backpressure ----------------------------------------------------------------

// Backpressure is per link: only what waits for a congested link waits.

void Network::Impl::onWritten(Link& link) {
  if (link.congested_ && link.backlog() < config_.coalesceAboveBytes / 2) {
    link.congested_ = false;
    if (events_.onWritable) events_.onWritable();
  }
}

bool Network::Impl::blocked(PeisId destination) {
  const PeisId next = table_.nextHop(destination);
  Link* link = next == 0 ? nullptr : findLink(next);
  if (!link) return false;  // unroutable: taken and counted when sent
  if (link->backlog() > config_.coalesceAboveBytes) link->congested_ = true;
  return link->congested_;
}

void Network::Impl::cutOff(PeisId destination, const std::string& reason) {
  const PeisId next = table_.nextHop(destination);
  Link* link = next == 0 ? nullptr : findLink(next);
  if (!link) return;
  ++counters_.slowPeersDisconnected;
  log::warn(self_, "closing the link to PEIS " + std::to_string(next) + ": " + reason);
  link->close(reason);
}

// --- Routing -----------------------------------------------------------------------

void Network::Impl::onRoutes(Link& link, wire::Routes& routes) {
  ++routesEpoch_;
  table_.onRoutes(link.peer_.id, routes.entries);
  // Adverts arrive in bursts: recompute once per burst.
  if (table_.hasWork()) scheduleRecompute();
}

void Network::Impl::onLeave(Link& link, const wire::Leave& leave) {
  // What the leaving PEIS sent before its Leave (the result of the write
  // that made it quit, say) is delivered before it is gone.
  flushInbox();
  if (!table_.onLeave(link.peer_.id, leave, SteadyClock::now())) return;
  log::debug(self_, "PEIS " + std::to_string(leave.id) + " left");
  for (const auto& other : links_) {  // pass it on, once
    if (other.get() != &link && other->established_) sendLinkMessage(*other, leave);
  }
  recompute();  // at once: it is gone for sure
}

void Network::Impl::afterTable() {
  for (auto& m : table_.takeMessages()) {
    if (auto* link = findLink(m.to)) sendLinkMessage(*link, m.message);
  }
  if (table_.hasAdverts()) scheduleAdvert();
  if (table_.hasWork()) scheduleRecompute();
  const auto deadline = table_.nextDeadline();
  if (!deadline || (holdArmed_ && *holdArmed_ <= *deadline) || stopped_) return;
  holdArmed_ = deadline;
  holdTimer_.expires_at(*deadline);
  holdTimer_.async_wait([this](const boost::system::error_code& ec) {
    if (ec == asio::error::operation_aborted) return;
    holdArmed_.reset();
    if (stopped_) return;
    ++routesEpoch_;
    recompute();
  });
}

void Network::Impl::recompute() {
  ++routesEpoch_;  // links or adverts changed (or may have): re-check sources
  if (const auto other = table_.takeCollision()) {
    ++counters_.idCollisions;
    collision(*other);
    return;
  }
  const auto changes = table_.recompute(SteadyClock::now());
  afterTable();
  retryHeld();
  for (const PeisId id : changes.down) {
    if (events_.onPeerDown) events_.onPeerDown(id);
  }
  for (const PeisId id : changes.up) {
    const auto* r = table_.find(id);
    if (!r || !events_.onPeerUp) continue;
    events_.onPeerUp(PeerInfo{id, r->name, r->incarnation, r->hops, r->nextHop, r->tool});
  }
  if (changes.topology && events_.onTopology) events_.onTopology();
}

// Runs `work` once for any number of requests: right after the handlers
// already queued (what one socket read brought) if it last ran at least
// `interval` ago, else `interval` after that last run. A lone change goes
// out at once; a stream of changes costs one run per interval.
void Network::Impl::throttle(Throttle& t, std::chrono::milliseconds interval,
                             void (Impl::*work)()) {
  if (t.scheduled || stopped_) return;
  t.scheduled = true;
  t.timer.expires_at(std::max(SteadyClock::now(), t.last + interval));
  t.timer.async_wait([this, &t, work](const boost::system::error_code& ec) {
    t.scheduled = false;
    if (ec || stopped_) return;
    t.last = SteadyClock::now();
    (this->*work)();
  });
}

void Network::Impl::scheduleRecompute() {
  throttle(recomputeThrottle_, kRecomputeDelay, &Impl::recompute);
}

void Network::Impl::scheduleAdvert() { throttle(advertThrottle_, kAdvertDelay, &Impl::advertise); }

void Network::Impl::advertise() {
  for (auto& [peer, routes] : table_.advertise()) {
    if (auto* link = findLink(peer)) sendLinkMessage(*link, routes);
  }
}

// --- Routed frames -------------------------------------------------------------------

// The message is inbox_.back(): it stays there only when it is for this PEIS.
void Network::Impl::onRouted(Link& link, std::string_view frame) {
  const auto envelope = inbox_.back().envelope;
  auto drop = [this] { inbox_.pop_back(); };
  if (envelope.source == self_) {  // our own frame came back: a transient loop
    ++counters_.unroutable;
    return drop();
  }
  // The checks below depend only on the source, the link and the routes: a
  // stream of frames from one source skips them while nothing changed.
  if (link.checkedSource_ != envelope.source || link.checkedEpoch_ != routesEpoch_) {
    // Its route may sit in an advert whose recompute is still pending.
    if (!table_.contains(envelope.source) && recomputeThrottle_.scheduled) {
      // recompute() may hand the inbox to the Kernel (retryHeld delivers
      // held frames): keep this message, not yet checked, out of it.
      auto message = std::move(inbox_.back());
      inbox_.pop_back();
      recompute();
      inbox_.push_back(std::move(message));
    }
    // A linked PEIS sends its own frames over its own link, so a frame
    // claiming its id from another link is spoofed, unless that link's PEIS
    // advertised a route to it: then it relays frames sent while routes were
    // changing (e.g. the full sync of a subscription made before the direct
    // link was up).
    const auto* direct = findLink(envelope.source);
    const bool relayed = table_.advertises(link.peer_.id, envelope.source);
    if (direct && direct != &link && !relayed) {
      ++counters_.malformedFrames;
      log::warn(self_, "dropped a frame from " + link.remote_ + " with spoofed source " +
                           std::to_string(envelope.source));
      drop();
      if (++link.malformed_ >= config_.maxMalformedFrames) {
        ++counters_.garbagePeersDisconnected;
        link.close("sent garbage");
      }
      return;
    }
    if (!table_.contains(envelope.source)) {
      // A PEIS we have no route to yet: the adverts naming it travel one hop
      // per advert delay, its first messages can be faster. Hold them briefly.
      if (held_.size() >= kMaxHeldFrames) {
        ++counters_.unroutable;
        return drop();
      }
      held_.push_back(Held{std::string(frame), std::move(inbox_.back()), SteadyClock::now()});
      return drop();
    }
    link.checkedSource_ = envelope.source;
    link.checkedEpoch_ = routesEpoch_;
  }
  if (envelope.destination == self_) return;  // stays in the inbox
  forwardFrame(frame, envelope);
  drop();
}

void Network::Impl::deliverOrForward(std::string_view frame, wire::RoutedMessage&& message) {
  if (message.envelope.destination == self_) {
    inbox_.push_back(std::move(message));
    return;
  }
  forwardFrame(frame, message.envelope);
}

void Network::Impl::forwardFrame(std::string_view frame, const wire::Envelope& envelope) {
  if (envelope.ttl <= 1) {
    ++counters_.unroutable;
    return;
  }
  std::string copy;
  copy.reserve(frame.size() + wire::kFrameHeaderBytes);
  const auto length = static_cast<std::uint32_t>(frame.size());
  for (int i = 0; i < 4; ++i) copy.push_back(static_cast<char>(length >> (24 - 8 * i)));
  copy.append(frame);
  auto routedEnvelope = envelope;
  --routedEnvelope.ttl;
  wire::reEnvelope(copy, routedEnvelope);
  forward(envelope.destination, std::move(copy), envelope.source);
}

// Frames held for an unknown source: process those whose source is now
// routable, drop those older than kHoldFor (counted as unroutable).
void Network::Impl::retryHeld() {
  for (auto n = heldAnswers_.size(); n > 0; --n) {
    auto [answer, arrived] = std::move(heldAnswers_.front());
    heldAnswers_.pop_front();
    if (table_.contains(answer.envelope.destination)) {
      forward(answer.envelope.destination, wire::encodeFrame(answer));
    } else if (SteadyClock::now() - arrived > kHoldFor) {
      ++counters_.unroutable;
    } else {
      heldAnswers_.emplace_back(std::move(answer), arrived);
    }
  }
  if (held_.empty()) return;
  const auto now = SteadyClock::now();
  std::deque<Held> keep;
  auto held = std::move(held_);
  held_.clear();
  for (auto& h : held) {
    if (table_.contains(h.message.envelope.source)) {
      deliverOrForward(h.frame, std::move(h.message));
    } else if (now - h.arrived > kHoldFor) {
      ++counters_.unroutable;
    } else {
      keep.push_back(std::move(h));
    }
  }
  for (auto& h : keep) held_.push_back(std::move(h));
  flushInbox();
}

void Network::Impl::flushInbox() {
  if (inbox_.empty()) return;
  std::vector<wire::RoutedMessage> messages;
  messages.swap(inbox_);
  inbox_.swap(spareInbox_);
  if (events_.onMessages) events_.onMessages(std::move(messages));
  messages.clear();  // the handler took the messages; keep the buffer
  if (spareInbox_.capacity() < messages.capacity()) spareInbox_.swap(messages);
}

Link* Network::Impl::nextHopLink(PeisId destination) {
  const PeisId next = table_.nextHop(destination);
  Link* link = next == 0 ? nullptr : findLink(next);
  if (!link) ++counters_.unroutable;
  return link;
}

bool Network::Impl::forward(PeisId destination, std::string frame, PeisId relayedFrom) {
  auto* link = nextHopLink(destination);
  if (!link) return false;
  // The next hop takes a frame claiming a linked PEIS's id from another link
  // for spoofed unless that link advertised a route to it: the advert must
  // not lag behind the frames relayed from that PEIS (adverts are batched).
  if (relayedFrom != 0) {
    if (auto one = table_.tellNow(link->peer_.id, relayedFrom)) sendLinkMessage(*link, *one);
  }
  link->sendFrame(frame);
  if (link->backlog() > config_.maxBacklogBytes) {
    ++counters_.slowPeersDisconnected;
    link->close("over " + std::to_string(config_.maxBacklogBytes >> 20) + " MiB queued");
  }
  return true;
}

bool Network::Impl::send(wire::RoutedMessage message) {
  message.envelope.source = self_;
  if (message.envelope.ttl == 0) message.envelope.ttl = wire::kDefaultTtl;
  return forward(message.envelope.destination, wire::encodeFrame(message));
}

bool Network::Impl::sendUpdate(PeisId destination, std::uint64_t incarnation,
                               const std::shared_ptr<const Tuple>& tuple) {
  auto* link = nextHopLink(destination);
  if (!link) return false;
  link->sendUpdate(wire::Envelope{self_, destination, wire::kDefaultTtl}, incarnation, tuple);
  return true;
}

bool Network::Impl::sendFrames(PeisId destination, std::string_view frames, std::uint32_t count) {
  const PeisId next = table_.nextHop(destination);
  Link* link = next == 0 ? nullptr : findLink(next);
  if (!link) {
    counters_.unroutable += count;
    return false;
  }
  link->sendBytes(frames, count);
  return true;
}

// --- Dial and prune ----------------------------------------------------------------

void Network::Impl::scheduleDials() {
  const auto now = SteadyClock::now();
  if (!dialsPending_) {
    dialsPending_ = true;
    dialsFirstAsked_ = now;
  }
  const auto due = std::min(now + kDialQuiet, dialsFirstAsked_ + kDialMaxDelay);
  dialTimer_.expires_at(due);
  dialTimer_.async_wait([this](const boost::system::error_code& ec) {
    if (ec || stopped_) return;
    dialsPending_ = false;
    evaluateDials();
  });
}

void Network::Impl::evaluateDials() {
  const auto ids = discovery_.sortedIds();
  // A tool dials every overlay peer it has (no other PEIS dials a tool).
  const auto targets = peersToDial(
      ids, self_, [this](PeisId id) { return findLink(id) != nullptr || dialing_.count(id) != 0; },
      config_.tool);
  for (const PeisId target : targets) {
    const auto* peer = discovery_.peer(target);
    if (!peer) continue;
    log::debug(self_, "dialling PEIS " + std::to_string(target) + " (overlay of " +
                          std::to_string(ids.size()) + ")");
    dialing_.insert(target);
    auto socket = std::make_shared<tcp::socket>(io_);
    socket->async_connect(tcp::endpoint(peer->address, peer->port),
                          [this, socket, target](const boost::system::error_code& ec) {
                            if (stopped_) return;
                            if (ec) {
                              dialing_.erase(target);
                              return;
                            }
                            addLink(std::move(*socket), true, -1, target);
                          });
  }
}

void Network::Impl::schedulePrune() {
  if (stopped_ || pruneArmed_) return;  // when it fires, it waits longer if needed
  armPrune(SteadyClock::now() + kLinkGrace);
}

void Network::Impl::armPrune(SteadyClock::time_point at) {
  pruneArmed_ = true;
  pruneTimer_.expires_at(at);
  pruneTimer_.async_wait([this](const boost::system::error_code& ec) {
    pruneArmed_ = false;
    if (ec || stopped_) return;
    // Settled: no membership change and no new discovered link for kLinkGrace.
    auto settled = discovery_.membershipChangedAt();
    for (const auto& link : links_) {
      if (link->established_ && link->explicitIndex_ < 0) {
        settled = std::max(settled, link->establishedAt_);
      }
    }
    if (SteadyClock::now() < settled + kLinkGrace) return armPrune(settled + kLinkGrace);
    pruneLinks();
    // The churn of a join (transient links, their buffers, held frames) has
    // settled: give the memory it freed back to the system instead of
    // keeping it resident for good (glibc keeps freed pages otherwise).
#ifdef __GLIBC__
    malloc_trim(0);
#endif
  });
}

// While PEIS join, the overlay's wanted pairs shift and links pile up; the
// lower id of a pair closes a discovered link the overlay no longer wants
// once it has settled for a while.
void Network::Impl::pruneLinks() {
  const auto now = SteadyClock::now();
  // Only once the membership has settled, so both ends agree on the overlay;
  // a tool, short-lived, keeps the few links it has.
  if (config_.tool || now - discovery_.membershipChangedAt() < kLinkGrace) return;
  const auto ids = discovery_.sortedIds();
  auto links = links_;
  for (const auto& link : links) {
    if (!link->established_) continue;
    const PeisId peer = link->peer_.id;
    const PruneQuestion question{peer,
                                 link->explicitIndex_ < 0,
                                 discovery_.knows(peer),
                                 now - link->establishedAt_,
                                 table_.hasAlternative(peer),
                                 (link->peer_.capabilities & wire::kCapabilityTool) != 0};
    if (shouldPrune(ids, self_, question)) link->close("not needed by the overlay");
  }
}

// --- Queries -----------------------------------------------------------------------

std::vector<PeerInfo> Network::Impl::peers() const {
  std::vector<PeerInfo> result;
  for (const auto& [id, route] : table_.routes()) {
    result.push_back(
        PeerInfo{id, route.name, route.incarnation, route.hops, route.nextHop, route.tool});
  }
  return result;
}

std::vector<LinkInfo> Network::Impl::links() const {
  std::vector<LinkInfo> result;
  for (const auto& link : links_) {
    if (!link->established_) continue;
    result.push_back(LinkInfo{link->peer_.id, link->peer_.name, link->remote_, link->outbound_,
                              link->backlog()});
  }
  return result;
}

// --- Network ------------------------------------------------------------------------

Network::Network(asio::io_context& io, NetworkConfig config, PeisId self, std::uint64_t incarnation,
                 Events events)
    : impl_(std::make_unique<Impl>(io, std::move(config), self, incarnation, std::move(events))) {}
Network::~Network() = default;
void Network::start() { impl_->start(); }
void Network::stop(std::function<void()> closed) { impl_->stop(std::move(closed)); }
bool Network::send(wire::RoutedMessage message) { return impl_->send(std::move(message)); }
bool Network::sendUpdate(PeisId destination, std::uint64_t incarnation,
                         const std::shared_ptr<const Tuple>& tuple) {
  return impl_->sendUpdate(destination, incarnation, tuple);
}
bool Network::sendFrames(PeisId destination, std::string_view frames, std::uint32_t count) {
  return impl_->sendFrames(destination, frames, count);
}
bool Network::blocked(PeisId destination) { return impl_->blocked(destination); }
void Network::cutOff(PeisId destination, const std::string& reason) {
  impl_->cutOff(destination, reason);
}
bool Network::reachable(PeisId id) const { return impl_->reachable(id); }
std::shared_ptr<Link> Network::linkTowards(PeisId destination) const {
  return impl_->linkTowards(destination);
}
std::size_t Network::congestedAboveBytes() const { return impl_->congestedAboveBytes(); }
std::vector<PeerInfo> Network::peers() const { return impl_->peers(); }
std::vector<LinkInfo> Network::links() const { return impl_->links(); }
const Counters& Network::counters() const { return impl_->counters_; }
std::uint16_t Network::port() const { return impl_->listenPort(); }
PeisId Network::self() const { return impl_->self_; }

}  // namespace peis::net
