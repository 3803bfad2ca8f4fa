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
#include <map>
#include <set>

#include "log.h"
#include "net/handshake.h"
#include "net/inbox.h"
#include "net/link.h"
#include "net/link_policy.h"
#include "net/link_security.h"
#include "net/routing_table.h"
#include "net/string_room.h"
#include "peis/error.h"
#include "peis/key.h"
#include "peis/options.h"
#include "security/crypto.h"
#include "security/identity.h"
#include "security/record_cipher.h"
#include "security/source_tag.h"

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
constexpr std::chrono::seconds kLimitLogEvery{10};
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
        discovery_(
            io,
            Discovery::Config{config_.ecology, config_.discovery, config_.discoveryPort,
                              config_.beaconPeriod, config_.tool, config_.credentials != nullptr},
            counters_, self, incarnation, discoveryEvents()),
        acceptor_(io),
        pingTimer_(io),
        redialTimer_(io),
        dialTimer_(io),
        acceptRetry_(io),
        pruneTimer_(io),
        holdTimer_(io),
        explicitLinks_(config_.connect.size()) {
    if (const auto& credentials = config_.credentials) {
      anchor_ = security::TrustAnchor{credentials->certificate.ecology, credentials->rootKey};
      ownIdentity_ = security::makeIdentity(*credentials, self_, incarnation_, config_.name);
      tags_ = std::make_unique<security::SourceTags>(*credentials);
    }
  }

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
    auto link = next == 0 ? nullptr : linkTo(next);
    // On a secured link, our frames over relays go with their SourceTags
    // (forward()), which a direct send does not make: only a neighbour's
    // own link takes them.
    if (link && link->security_ && next != destination) return nullptr;
    return link;
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
  // A big TupleUpdate for this PEIS on an open link: its data is read
  // straight into the tuple's (net/link.h, "placed frames").
  char* placeFrame(Link& link, std::string_view head, std::size_t length,
                   std::size_t& from) override;
  char* reservePlace(Link& link, std::size_t bytes) override;
  bool placeReserved(Link& link, std::string_view head, std::size_t length) override;
  void onPlacedFrame(Link& link) override;
  void onReadDone(Link&) override { flushInbox(); }
  void onWritten(Link& link) override;
  void onClosed(Link& link, const std::string& reason) override;

  Counters counters_;
  PeisId self_;
  const security::Identity* identityOf(PeisId id) const { return book_.find(id); }
  std::size_t recheckIdentities();

 private:
  // --- secured ecologies (docs/protocol.md §15)
  bool secured() const { return config_.credentials != nullptr; }
  // The peer's Hello on a secured link: keys, records, our Auth.
  void onSecuredHello(Link& link, const wire::Hello& hello, std::string_view frame);
  void onAuth(Link& link, const wire::Auth& auth);
  void onIdentity(Link& link, const wire::Identity& identity);
  // Refuses a peer at the handshake: closed, counted, logged with the reason.
  void refuse(Link& link, const std::string& reason);
  // The route entries a secured PEIS takes from `link`: those of PEIS whose
  // identity (incarnation and name) it checked; the others are dropped.
  void keepEntitled(Link& link, std::vector<wire::RouteEntry>& entries);
  // Whether a frame relayed from `source` carries its source's tag.
  bool tagHolds(PeisId source, const std::string& tag, std::string_view frame);
  void sendTag(Link& link, std::string tag);
  // Sends `routes` on `link`, the identities of its PEIS first (secured).
  void sendRoutes(Link& link, const wire::Routes& routes);
  void forgetIdentities();
  std::size_t maxFrameBytes() const { return config_.maxDataBytes + wire::kMaxFrameOverhead; }
  static RoutingTable::Config tableConfig(const NetworkConfig& config, PeisId self,
                                          std::uint64_t incarnation);
  Discovery::Events discoveryEvents();
  // --- links and the handshake
  void accept();
  void dial(const std::string& host, std::uint16_t port, int explicitIndex);
  void addLink(tcp::socket socket, bool outbound, int explicitIndex, PeisId dialTarget = 0);
  void onHello(Link& link, const wire::Hello& hello, std::string_view frame);
  // Judges a Hello (checked by an Auth in a secured ecology) and
  // establishes the link, or closes it.
  void establishOrClose(Link& link, const wire::Hello& hello);
  void onMalformed(Link& link, const std::string& error);
  void collision(std::uint64_t otherIncarnation);
  bool mayGiveUpId() const {
    if (secured() && config_.credentials->certificate.pinnedId == self_) return false;
    return SteadyClock::now() - startedAt_ < config_.idClaimWindow;
  }
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
  std::string* placedData(Link& link);
  bool decodePlaced(Link& link, std::string_view head, std::size_t length, std::size_t& from);
  void deliverOrForward(std::string_view frame, wire::RoutedMessage&& message, PeisId from,
                        const std::string& tag);
  void forwardFrame(std::string_view frame, const wire::Envelope& envelope,
                    const std::string& tag = {});
  // `relayedFrom`: the source of a frame this PEIS relays (0: its own);
  // `tag`: its SourceTag, passed on with it.
  bool forward(PeisId destination, std::string frame, PeisId relayedFrom = 0,
               const std::string& tag = {});
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
  // A limit was hit: counts it and logs it, at most once per kLimitLogEvery
  // for each kind (a flood must not flood the log too).
  void limitHit(std::uint64_t& counter, const std::string& kind, const std::string& message,
                std::uint64_t count = 1);
  // Whether a routed frame from `source` may arrive over `link` (the
  // spoofing checks of docs/protocol.md §14).
  bool sourceMayArriveOver(const Link& link, const wire::Envelope& envelope,
                           SteadyClock::time_point now) const;

  asio::io_context& io_;
  NetworkConfig config_;
  std::uint64_t incarnation_;
  Events events_;
  bool stopped_ = false;
  const SteadyClock::time_point startedAt_ = SteadyClock::now();
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
    PeisId from = 0;  // the linked PEIS it came from
    std::string tag;  // its SourceTag (secured ecologies)
  };
  std::deque<Held> held_;
  std::size_t heldBytes_ = 0;  // of the frames in held_ (Limits::maxHeldBytes)
  std::map<std::string, SteadyClock::time_point> limitLogged_;
  security::TrustAnchor anchor_;
  std::optional<security::Identity> ownIdentity_;
  security::IdentityBook book_;
  std::unique_ptr<security::SourceTags> tags_;
  // Answers to frames over the data limit (onOversize) for a PEIS with no
  // route yet (its first frames can be faster than its route, as above):
  // sent once it has one, dropped after kHoldFor.
  std::deque<std::pair<wire::RoutedMessage, SteadyClock::time_point>> heldAnswers_;
  // Messages for this PEIS, handed over together once a read is parsed. Two
  // inboxes take turns (a handler may parse frames held back meanwhile),
  // and their messages are decoded into again by the next reads.
  Inbox inbox_;
  Inbox spareInbox_;
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
  c.maxRoutes = config.maxRoutes;
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
  h.capabilities = wire::kCapabilityCoalescing | (config_.tool ? wire::kCapabilityTool : 0) |
                   (secured() ? wire::kCapabilitySecured : 0);
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
      boost::system::error_code e;
      const auto remote = socket.remote_endpoint(e);
      const auto address = e ? std::string("?") : remote.address().to_string();
      std::size_t pendingFromHost = 0;
      for (const auto& link : links_) {
        if (!link->established_ && link->remoteAddress_ == address) ++pendingFromHost;
      }
      if (links_.size() >= config_.maxConnections) {
        limitHit(counters_.connectionsRefused, "connections",
                 "refused a connection from " + address + ": " +
                     std::to_string(config_.maxConnections) +
                     " connections are open (--peis-max-connections)");
        socket.close(e);
      } else if (pendingFromHost >= config_.maxHandshakesPerHost) {
        limitHit(counters_.connectionsRefused, "handshakes-per-host",
                 "refused a connection from " + address + ": " + std::to_string(pendingFromHost) +
                     " of its connections are in their handshake "
                     "(--peis-max-handshakes-per-host)");
        socket.close(e);
      } else {
        addLink(std::move(socket), false, -1);
      }
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
  if (outbound && links_.size() >= config_.maxConnections) {
    if (dialTarget != 0) dialing_.erase(dialTarget);
    limitHit(counters_.connectionsRefused, "connections",
             "did not open a dialled link: " + std::to_string(config_.maxConnections) +
                 " connections are open (--peis-max-connections)");
    return;
  }
  auto link = std::make_shared<Link>(*this, counters_, maxFrameBytes(), std::move(socket), outbound,
                                     explicitIndex);
  link->dialTarget_ = dialTarget;
  links_.push_back(link);
  if (explicitIndex >= 0) explicitLinks_[static_cast<std::size_t>(explicitIndex)] = link;
  auto h = hello();
  if (secured()) {
    link->security_ = std::make_unique<LinkSecurity>();
    link->security_->handshake =
        std::make_unique<security::LinkHandshake>(*config_.credentials, outbound);
    h.auth = link->security_->handshake->helloAuth();
  }
  link->start(h);
  // The handshake's deadline: a connection that does not say who it is in
  // time (or sends its Hello a byte at a time) is closed.
  auto deadline = std::make_shared<asio::steady_timer>(io_, config_.handshakeTimeout);
  deadline->async_wait([this, deadline,
                        weak = std::weak_ptr<Link>(link)](const boost::system::error_code& ec) {
    auto l = weak.lock();
    if (ec || stopped_ || !l || l->closed() || l->established_) return;
    limitHit(counters_.handshakeTimeouts, "handshake",
             "closed " + l->remote_ + ": no handshake within " +
                 std::to_string(config_.handshakeTimeout.count()) + " ms (--peis-handshake-ms)");
    l->close("no handshake in time");
  });
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
  if (auto* hello = std::get_if<wire::Hello>(&message)) return onHello(link, *hello, frame);
  if (auto* auth = std::get_if<wire::Auth>(&message)) return onAuth(link, *auth);
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
  } else if (std::get_if<wire::IdTaken>(&message)) {
    // A collision is decided by the Hellos, on the link that shows it,
    // which both ends close; on an established link (whose peer holds
    // another id) an IdTaken is made up.
    onMalformed(link, "IdTaken on an established link");
  } else if (auto* identity = std::get_if<wire::Identity>(&message)) {
    onIdentity(link, *identity);
  } else if (auto* tag = std::get_if<wire::SourceTag>(&message)) {
    if (!link.security_) return onMalformed(link, "a SourceTag on an open link");
    link.security_->pendingTag = std::move(tag->tag);
  }
}

char* Network::Impl::placeFrame(Link& link, std::string_view head, std::size_t length,
                                std::size_t& from) {
  auto* data = placedData(link);
  if (!data || !decodePlaced(link, head, length, from)) return nullptr;
  // Sized, not zero-filled: the link writes every byte.
  data->clear();
  resizeForOverwrite(*data, length - from);
  return data->data();
}

char* Network::Impl::reservePlace(Link& link, std::size_t bytes) {
  auto* data = placedData(link);
  if (!data) return nullptr;
  if (data->size() != bytes) {  // else reserved before and not used
    data->clear();
    resizeForOverwrite(*data, bytes);
  }
  return data->data();
}

bool Network::Impl::placeReserved(Link& link, std::string_view head, std::size_t length) {
  std::size_t from = 0;
  return decodePlaced(link, head, length, from) && from == head.size();
}

// The data of the message a link places; null on a link whose frames are
// read whole (a secured link's come out of its records).
std::string* Network::Impl::placedData(Link& link) {
  if (!link.established_ || link.security_) return nullptr;
  if (!link.placed_) link.placed_ = std::make_unique<wire::RoutedMessage>();
  auto* update = std::get_if<wire::TupleUpdate>(&link.placed_->body);
  if (!update) update = &link.placed_->body.emplace<wire::TupleUpdate>();
  return &update->tuple.data;
}

// The head of a frame a link places into its message: a TupleUpdate for
// this PEIS (a frame passing through is forwarded as bytes: read whole).
bool Network::Impl::decodePlaced(Link& link, std::string_view head, std::size_t length,
                                 std::size_t& from) {
  return wire::decodeTupleUpdateHead(head, length, config_.maxDataBytes, *link.placed_, from) &&
         link.placed_->envelope.destination == self_;
}

// As onFrame's routed frames: into the inbox, then onRouted's checks.
void Network::Impl::onPlacedFrame(Link& link) {
  ++counters_.framesIn;
  inbox_.push_back(std::move(*link.placed_));
  onRouted(link, {});
}

bool Network::Impl::onOversize(Link& link, std::string_view head) {
  if (link.security_) link.security_->pendingTag.clear();
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

void Network::Impl::onHello(Link& link, const wire::Hello& hello, std::string_view frame) {
  if (!link.established_) {
    const bool theirs = (hello.capabilities & wire::kCapabilitySecured) != 0;
    if (theirs != secured() && hello.version == wire::kVersion &&
        hello.ecology == config_.ecology) {
      // A secured and an open ecology of one name never mix.
      return refuse(link, secured() ? "an open PEIS (no credentials) may not join this secured "
                                      "ecology"
                                    : "it belongs to a secured ecology and this PEIS has no "
                                      "credentials (--peis-credentials)");
    }
    if (secured()) return onSecuredHello(link, hello, frame);
  }
  establishOrClose(link, hello);
}

void Network::Impl::establishOrClose(Link& link, const wire::Hello& hello) {
  const auto existing = linkTo(hello.id);
  HelloContext context{self_, incarnation_, config_.ecology, link.established_, link.outbound_};
  context.mayGiveUpId = mayGiveUpId();
  if (existing) {
    context.existing = &existing->peer_;
    context.existingOutbound = existing->outbound_;
  }
  bool replaces = false;
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
    case HelloVerdict::IdKept:
      ++counters_.idCollisions;
      log::warn(self_, link.remote_ + " claims id " + std::to_string(self_) +
                           " with an earlier start; keeping it (this PEIS has held it for " +
                           "longer than the join window)");
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
      replaces = true;
      break;
    case HelloVerdict::Establish:
      break;
  }
  link.establish();
  ++routesEpoch_;
  link.establishedAt_ = SteadyClock::now();
  if (link.explicitIndex_ < 0) schedulePrune();
  link.peer_ = hello;
  dialing_.erase(hello.id);
  log::info(self_, "linked to PEIS " + std::to_string(hello.id) + " '" + hello.name + "' at " +
                       link.remote_ + (link.outbound_ ? " (dialled)" : " (accepted)"));
  table_.linkUp(hello);
  recompute();
  // The routes are as they were (the table keeps the old link's advert), but
  // whoever holds the old link (the kernel's direct sends) must take the new.
  if (replaces && events_.onTopology) events_.onTopology();
  // The new link gets the whole table now; the others hear of the new route
  // with the next advert.
  if (link.closed()) return;
  auto all = table_.fullAdvert(hello.id);
  if (!all.entries.empty()) sendRoutes(link, all);
}

// --- Secured ecologies ------------------------------------------------------------

void Network::Impl::refuse(Link& link, const std::string& reason) {
  if (limitLogged_.size() > 256) limitLogged_.clear();  // reasons name PEIS: keep it bounded
  limitHit(counters_.authRefused, "refused: " + reason,
           "refused " + link.remote_ +
               (link.peer_.id != 0 ? " (claims PEIS " + std::to_string(link.peer_.id) + ")" : "") +
               ": " + reason);
  link.close("refused: " + reason);
}

void Network::Impl::onSecuredHello(Link& link, const wire::Hello& hello, std::string_view frame) {
  auto& sec = *link.security_;
  if (sec.keyed) {  // a second Hello
    ++link.malformed_;
    return;
  }
  if (hello.version != wire::kVersion) {
    return link.close("protocol version " + std::to_string(hello.version) + " is not " +
                      std::to_string(wire::kVersion));
  }
  if (hello.ecology != config_.ecology) {
    ++counters_.foreignEcologyRejected;
    return link.close("peer belongs to ecology '" + hello.ecology + "'");
  }
  if (auto error = sec.handshake->onPeerHello(hello.auth, link.ownHello(), frame)) {
    return refuse(link, *error);
  }
  // Nothing of this Hello is believed until its Auth proves it.
  link.peer_ = hello;
  link.secure(std::make_unique<security::RecordCipher>(
      sec.handshake->suite(), sec.handshake->sendKey(), sec.handshake->receiveKey()));
  sec.keyed = true;
  sendLinkMessage(link, wire::Auth{security::encodeIdentity(*ownIdentity_),
                                   sec.handshake->transcriptSignature()});
}

void Network::Impl::onAuth(Link& link, const wire::Auth& auth) {
  if (!link.security_ || !link.security_->keyed || link.security_->peer || link.established_) {
    return onMalformed(link, "an Auth out of place");
  }
  auto& sec = *link.security_;
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(
                       std::chrono::system_clock::now().time_since_epoch())
                       .count();
  auto checked = sec.handshake->checkAuth(auth.identity, auth.signature, link.peer_.id,
                                          link.peer_.incarnation, link.peer_.name, anchor_, now);
  if (auto* error = std::get_if<std::string>(&checked)) return refuse(link, *error);
  auto& identity = std::get<security::Identity>(checked);
  if (events_.refuseIdentity) {
    if (auto why = events_.refuseIdentity(identity)) return refuse(link, *why);
  }
  log::debug(self_, "PEIS " + std::to_string(identity.id) + " at " + link.remote_ + " proved " +
                        security::describe(identity.certificate));
  sec.handshake.reset();
  sec.identitiesSent[self_] = incarnation_;                // ours went in our Auth
  sec.identitiesSent[identity.id] = identity.incarnation;  // it knows its own
  book_.put(identity);
  sec.peer = std::move(identity);
  establishOrClose(link, link.peer_);
}

void Network::Impl::onIdentity(Link& link, const wire::Identity& message) {
  if (!link.security_) return onMalformed(link, "an Identity on an open link");
  std::string error;
  std::string_view in = message.identity;
  auto identity = security::decodeIdentity(in, error);
  if (!identity || !in.empty()) return onMalformed(link, "broken identity: " + error);
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(
                       std::chrono::system_clock::now().time_since_epoch())
                       .count();
  auto problem = security::identityProblem(*identity, anchor_, now);
  if (!problem && events_.refuseIdentity) problem = events_.refuseIdentity(*identity);
  if (problem) {
    ++counters_.unentitled;
    return onMalformed(
        link, "identity of PEIS " + std::to_string(identity->id) + " refused: " + *problem);
  }
  if (identity->id == self_) return;  // ours, or a claim of it: never taken from others
  if (!book_.find(identity->id) && book_.size() >= config_.maxRoutes + links_.size()) {
    forgetIdentities();
    if (book_.size() >= config_.maxRoutes + links_.size()) {
      return limitHit(counters_.routesRefused, "identities",
                      "refused an identity from PEIS " + std::to_string(link.peer_.id) +
                          ": over --peis-max-routes identities are known");
    }
  }
  book_.put(std::move(*identity));
}

// Identities of PEIS no route and no neighbour's advert names any more.
void Network::Impl::forgetIdentities() {
  book_.forgetIf([&](PeisId id) {
    if (table_.contains(id)) return false;
    for (const auto& link : links_) {
      if (link->established_ && (link->peer_.id == id || table_.advertises(link->peer_.id, id)))
        return false;
    }
    return true;
  });
}

void Network::Impl::keepEntitled(Link& link, std::vector<wire::RouteEntry>& entries) {
  const auto before = entries.size();
  std::erase_if(entries, [&](const wire::RouteEntry& e) {
    if (e.hops == RoutingTable::kWithdrawn) return false;
    if (e.id == self_) return true;  // never ours from another
    if (e.id == link.peer_.id) {
      return e.incarnation != link.peer_.incarnation || e.name != link.peer_.name;
    }
    return !book_.vouches(e.id, e.incarnation, e.name);
  });
  if (entries.size() < before) {
    limitHit(counters_.unentitled, "unentitled routes",
             "dropped " + std::to_string(before - entries.size()) + " route entries from PEIS " +
                 std::to_string(link.peer_.id) +
                 " naming PEIS (or names) whose identity it did not prove",
             before - entries.size());
  }
}

bool Network::Impl::tagHolds(PeisId source, const std::string& tag, std::string_view frame) {
  const auto* identity = book_.find(source);
  if (identity && !tag.empty() && tags_->check(identity->certificate.publicKey, tag, frame)) {
    return true;
  }
  ++counters_.malformedFrames;
  limitHit(counters_.unentitled, "untagged",
           "dropped a frame relayed from PEIS " + std::to_string(source) +
               (tag.empty() ? " without its source tag" : " whose source tag does not hold"));
  return false;
}

void Network::Impl::sendTag(Link& link, std::string tag) {
  sendLinkMessage(link, wire::SourceTag{std::move(tag)});
}

void Network::Impl::sendRoutes(Link& link, const wire::Routes& routes) {
  if (link.security_) {
    auto& sent = link.security_->identitiesSent;
    for (const auto& e : routes.entries) {
      if (e.hops == RoutingTable::kWithdrawn) {
        sent.erase(e.id);  // told again with the route, if it comes back
        continue;
      }
      const auto it = sent.find(e.id);
      if (it != sent.end() && it->second == e.incarnation) continue;
      const auto* identity = e.id == self_ ? &*ownIdentity_ : book_.find(e.id);
      if (!identity || identity->incarnation != e.incarnation) continue;
      sendLinkMessage(link, wire::Identity{security::encodeIdentity(*identity)});
      sent[e.id] = e.incarnation;
    }
  }
  sendLinkMessage(link, routes);
}

std::size_t Network::Impl::recheckIdentities() {
  if (!secured() || !events_.refuseIdentity) return 0;
  std::size_t closed = 0;
  auto links = links_;
  for (auto& link : links) {
    if (!link->security_ || !link->security_->peer) continue;
    if (auto why = events_.refuseIdentity(*link->security_->peer)) {
      ++closed;
      refuse(*link, *why);
    }
  }
  book_.forgetIf([&](PeisId id) {
    const auto* identity = book_.find(id);
    return identity && events_.refuseIdentity(*identity).has_value();
  });
  return closed;
}

void Network::Impl::collision(std::uint64_t otherIncarnation) {
  if (otherIncarnation != 0 && otherIncarnation > incarnation_) return;  // the other re-picks
  if (!mayGiveUpId()) {
    log::warn(self_, "another PEIS claims id " + std::to_string(self_) +
                         " and an earlier start; keeping it (held longer than the join window)");
    return;
  }
  const PeisId old = self_;
  self_ = events_.repickId ? events_.repickId() : old;
  log::warn(old, "id " + std::to_string(old) + " is held by a PEIS that started earlier; now " +
                     std::to_string(self_));
  table_.reset(self_);
  ++routesEpoch_;
  if (secured()) {
    ownIdentity_ = security::makeIdentity(*config_.credentials, self_, incarnation_, config_.name);
  }
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
  // Every ping period, or sooner when a link's silence reaches the liveness
  // time before then: a frozen peer is dropped when its time is up, not up
  // to a ping period later. A link heard within the last few periods (any
  // peer that lives answers our pings) never brings the wake forward.
  // (A link already past it, kept by the checks below, waits for the period.)
  const auto now = SteadyClock::now();
  auto next = now + config_.pingPeriod;
  for (const auto& link : links_) {
    const auto dead = link->lastHeard_ + config_.deadAfter + std::chrono::milliseconds(1);
    if (dead > now && dead < next) next = dead;
  }
  pingTimer_.expires_at(next);
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
  if (link.security_) keepEntitled(link, routes.entries);
  const auto refused = table_.refused();
  table_.onRoutes(link.peer_.id, routes.entries);
  if (table_.refused() > refused) {
    limitHit(counters_.routesRefused, "routes",
             "refused " + std::to_string(table_.refused() - refused) + " route entries from " +
                 "PEIS " + std::to_string(link.peer_.id) + ": over " +
                 std::to_string(config_.maxRoutes) + " routes (--peis-max-routes)",
             table_.refused() - refused);
  }
  // Adverts arrive in bursts: recompute once per burst.
  if (table_.hasWork()) scheduleRecompute();
}

void Network::Impl::onLeave(Link& link, const wire::Leave& leave) {
  // What the leaving PEIS sent before its Leave (the result of the write
  // that made it quit, say) is delivered before it is gone.
  flushInbox();
  const bool neighbourLeaves = leave.id == link.peer_.id;
  if (table_.onLeave(link.peer_.id, leave, SteadyClock::now())) {
    log::debug(self_, "PEIS " + std::to_string(leave.id) + " left");
    for (const auto& other : links_) {  // pass it on, once
      if (other.get() != &link && other->established_) sendLinkMessage(*other, leave);
    }
    recompute();  // at once: it is gone for sure
  }
  // A neighbour that leaves closes its end right after its Leave. The read
  // that took the Leave may have taken that end of the stream too, and a
  // drained read does not look again (link_socket.h): close ours now.
  if (neighbourLeaves) link.close("left");
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
  const auto refused = table_.refused();
  const auto changes = table_.recompute(SteadyClock::now());
  if (table_.refused() > refused) {
    limitHit(counters_.routesRefused, "routes",
             "the routing table is full: " + std::to_string(config_.maxRoutes) +
                 " routes (--peis-max-routes)",
             table_.refused() - refused);
  }
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

void Network::Impl::limitHit(std::uint64_t& counter, const std::string& kind,
                             const std::string& message, std::uint64_t count) {
  counter += count;
  const auto now = SteadyClock::now();
  auto [it, first] = limitLogged_.try_emplace(kind, now);
  if (!first && now - it->second < kLimitLogEvery) return;
  it->second = now;
  log::warn(self_, message + " [" + kind + " limit hit " + std::to_string(counter) + " times]");
}

void Network::Impl::scheduleRecompute() {
  throttle(recomputeThrottle_, kRecomputeDelay, &Impl::recompute);
}

void Network::Impl::scheduleAdvert() { throttle(advertThrottle_, kAdvertDelay, &Impl::advertise); }

void Network::Impl::advertise() {
  for (auto& [peer, routes] : table_.advertise()) {
    if (auto* link = findLink(peer)) sendRoutes(*link, routes);
  }
}

// --- Routed frames -------------------------------------------------------------------

// The message is inbox_.back(): it stays there only when it is for this PEIS.
// `frame` is empty for a placed frame (a TupleUpdate for this PEIS from an
// open link, never forwarded): its bytes, needed only if it is held, are
// encoded again from the message then.
void Network::Impl::onRouted(Link& link, std::string_view frame) {
  const auto envelope = inbox_.back().envelope;
  std::string placedBytes;
  auto drop = [this] { inbox_.pop_back(); };
  // A secured link: the frame's SourceTag, if one came right before it.
  std::string tag;
  if (link.security_) tag = std::exchange(link.security_->pendingTag, std::string());
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
    const auto now = SteadyClock::now();
    if (!sourceMayArriveOver(link, envelope, now)) {
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
    if (!table_.contains(envelope.source) &&
        table_.sentBeforeLeaving(link.peer_.id, envelope.source, now, config_.relayGrace)) {
      // Sent before its Leave, which came faster another way: taken or
      // passed on (its route is gone, so holding it would only drop it).
    } else if (!table_.contains(envelope.source)) {
      // A PEIS we have no route to yet: the adverts naming it travel one hop
      // per advert delay, its first messages can be faster. Hold them
      // briefly, within bounds (Limits::maxHeldBytes).
      if (frame.empty()) {  // a placed frame
        placedBytes = wire::encodeFrame(inbox_.back()).substr(wire::kFrameHeaderBytes);
        frame = placedBytes;
      }
      if (held_.size() >= kMaxHeldFrames || heldBytes_ + frame.size() > config_.maxHeldBytes) {
        ++counters_.unroutable;
        limitHit(counters_.heldFramesDropped, "held",
                 "dropped a frame from unknown PEIS " + std::to_string(envelope.source) + ": " +
                     std::to_string(held_.size()) + " frames of " + std::to_string(heldBytes_) +
                     " bytes wait for their routes (--peis-max-held-bytes)");
        return drop();
      }
      heldBytes_ += frame.size();
      held_.push_back(
          Held{std::string(frame), std::move(inbox_.back()), now, link.peer_.id, std::move(tag)});
      return drop();
    }
    // Remembered only when it holds until the routes change (not when it
    // held for a grace period that may end first).
    if (link.peer_.id == envelope.source || table_.nextHop(envelope.source) == link.peer_.id) {
      link.checkedSource_ = envelope.source;
      link.checkedEpoch_ = routesEpoch_;
    }
  }
  if (envelope.destination == self_) {
    // In a secured ecology a frame from further away proves its source.
    if (link.security_ && envelope.source != link.peer_.id &&
        !tagHolds(envelope.source, tag, frame)) {
      return drop();
    }
    return;  // stays in the inbox
  }
  // A placed frame was for this PEIS when its head came; if this PEIS took
  // another id meanwhile, it has no bytes to forward: dropped, counted.
  if (frame.empty()) {
    ++counters_.unroutable;
    return drop();
  }
  forwardFrame(frame, envelope, tag);
  drop();
}

// A linked PEIS sends its own frames over its own link: a frame for this
// PEIS claiming its id from another link is spoofed, unless that link is the
// one our route to it went through until moments ago, or, moments after the
// link came up, its PEIS offers a route to it (frames sent while the routes
// were changing, such as the full sync of a subscription made before the
// direct link came up). A frame passing through may also come from a
// neighbour that offers a route to its source: the source chose that way
// while an advert was on its way (its destination checks it again). A frame
// from a PEIS that is not linked must come from our next hop to it, or a
// neighbour that offers a route to it at least as short (routes may be
// asymmetric only between equals), or the next hop of moments ago.
bool Network::Impl::sourceMayArriveOver(const Link& link, const wire::Envelope& envelope,
                                        SteadyClock::time_point now) const {
  if (link.peer_.id == envelope.source) return true;
  if (table_.mayRelay(link.peer_.id, envelope.source, now, config_.relayGrace)) return true;
  return envelope.destination != self_ && table_.advertises(link.peer_.id, envelope.source);
}

void Network::Impl::deliverOrForward(std::string_view frame, wire::RoutedMessage&& message,
                                     PeisId from, const std::string& tag) {
  if (message.envelope.destination == self_) {
    if (secured() && message.envelope.source != from &&
        !tagHolds(message.envelope.source, tag, frame)) {
      return;
    }
    inbox_.push_back(std::move(message));
    return;
  }
  forwardFrame(frame, message.envelope, tag);
}

void Network::Impl::forwardFrame(std::string_view frame, const wire::Envelope& envelope,
                                 const std::string& tag) {
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
  forward(envelope.destination, std::move(copy), envelope.source, tag);
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
  heldBytes_ = 0;
  for (auto& h : held) {
    const auto source = h.message.envelope.source;
    if (table_.contains(source)) {
      // Checked again now that the source has a route: the PEIS it came
      // from must be one it may come from.
      const auto* from = findLink(h.from);
      if (from && sourceMayArriveOver(*from, h.message.envelope, now)) {
        deliverOrForward(h.frame, std::move(h.message), h.from, h.tag);
      } else {
        ++counters_.malformedFrames;
      }
    } else if (now - h.arrived > kHoldFor) {
      ++counters_.unroutable;
    } else {
      heldBytes_ += h.frame.size();
      keep.push_back(std::move(h));
    }
  }
  for (auto& h : keep) held_.push_back(std::move(h));
  flushInbox();
}

void Network::Impl::flushInbox() {
  if (inbox_.empty()) return;
  Inbox messages;
  messages.swap(inbox_);
  inbox_.swap(spareInbox_);
  if (events_.onMessages) events_.onMessages(messages.messages());
  messages.clear();  // the handler took what it keeps; the messages stay for reuse
  if (spareInbox_.capacity() < messages.capacity()) spareInbox_.swap(messages);
}

Link* Network::Impl::nextHopLink(PeisId destination) {
  const PeisId next = table_.nextHop(destination);
  Link* link = next == 0 ? nullptr : findLink(next);
  if (!link) ++counters_.unroutable;
  return link;
}

bool Network::Impl::forward(PeisId destination, std::string frame, PeisId relayedFrom,
                            const std::string& tag) {
  auto* link = nextHopLink(destination);
  if (!link) return false;
  // The next hop takes a frame claiming a linked PEIS's id from another link
  // for spoofed unless that link advertised a route to it: the advert must
  // not lag behind the frames relayed from that PEIS (adverts are batched).
  if (relayedFrom != 0) {
    if (auto one = table_.tellNow(link->peer_.id, relayedFrom)) sendRoutes(*link, *one);
  }
  if (!tag.empty()) {
    sendTag(*link, tag);  // relayed with the frame it proves
  } else if (relayedFrom == 0 && secured() && link->peer_.id != destination) {
    // Ours, over relays: it proves its source to its destination.
    if (const auto* identity = book_.find(destination)) {
      sendTag(*link, tags_->tag(identity->certificate.publicKey,
                                std::string_view(frame).substr(wire::kFrameHeaderBytes)));
    }
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
  if (link->security_ && link->peer_.id != destination) {  // over relays: tagged
    std::string frame;
    wire::encodeTupleUpdate(wire::Envelope{self_, destination, wire::kDefaultTtl}, incarnation,
                            *tuple, frame);
    return forward(destination, std::move(frame));
  }
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
  if (link->security_ && next != destination) {  // over relays: each frame tagged
    while (frames.size() >= wire::kFrameHeaderBytes) {
      const auto bytes = wire::kFrameHeaderBytes + wire::frameLength(frames);
      forward(destination, std::string(frames.substr(0, bytes)));
      frames.remove_prefix(std::min(bytes, frames.size()));
    }
    return true;
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
const security::Identity* Network::identityOf(PeisId id) const { return impl_->identityOf(id); }
std::size_t Network::recheckIdentities() { return impl_->recheckIdentities(); }
std::uint16_t Network::port() const { return impl_->listenPort(); }
PeisId Network::self() const { return impl_->self_; }

}  // namespace peis::net
