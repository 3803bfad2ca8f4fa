// Network implementation: links, handshake, liveness, discovery, routing.
// See network.h for the contract and docs/protocol.md for the bytes.
#include "net/network.h"

#include <ifaddrs.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <net/if.h>
#include <netinet/in.h>

#include <algorithm>
#include <array>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ip/udp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>
#include <boost/container/flat_map.hpp>
#include <cstring>
#include <deque>
#include <map>
#include <set>

#include "log.h"
#include "net/beacon.h"
#include "net/overlay.h"
#include "peis/error.h"
#include "peis/key.h"
#include "peis/options.h"

namespace peis::net {
namespace asio = boost::asio;
using asio::ip::tcp;
using asio::ip::udp;
using SteadyClock = std::chrono::steady_clock;

namespace {

constexpr int kMaxHops = 32;
constexpr std::uint8_t kWithdrawn = 255;  // a route entry that is no longer valid
// A link reads at most readRoom_ bytes at a time: 4 KiB at first (an idle
// link's buffer stays small), doubling up to 32 KiB while reads fill it
// (64 KiB reads measured slower: a read's tuples then outgrow the caches).
constexpr std::size_t kFirstReadRoom = 4 * 1024;
constexpr std::size_t kMaxReadRoom = 32 * 1024;
constexpr std::size_t kWriteChunk = 256 * 1024;
constexpr std::size_t kFirstChunkBytes = 4 * 1024;  // a new write chunk's first memory
// Tuple data from this size on is written from the tuple, not copied.
constexpr std::size_t kZeroCopyBytes = wire::kZeroCopyDataBytes;
constexpr std::size_t kGatherChunks = 16;  // chunks per gathered write, at most
constexpr std::size_t kGatherBytes = 1024 * 1024;
constexpr std::chrono::milliseconds kAdvertDelay{100};  // adverts at most every 100 ms
constexpr std::chrono::milliseconds kRedialPeriod{1000};
constexpr std::chrono::seconds kLinkGrace{2};  // a link's minimum life before pruning
constexpr std::chrono::milliseconds kDialQuiet{15};
constexpr std::chrono::milliseconds kRecomputeDelay{20};  // recomputes at most every 20 ms
constexpr std::chrono::seconds kHoldFor{3};  // how long a frame waits for its source's route
constexpr std::size_t kMaxHeldFrames = 1024;
constexpr std::chrono::milliseconds kDialMaxDelay{1000};
constexpr int kMaxBeaconBackoff = 8;      // beacon period at most 8x the configured one
constexpr std::size_t kBeaconQuorum = 3;  // beacons heard that make a stable PEIS skip its own

// What a link's peer last heard from us about one route (for deltas).
struct ToldRoute {
  std::uint64_t incarnation = 0;
  std::size_t nameHash = 0;
  int hops = 0;
  static std::size_t hash(const std::string& name) { return std::hash<std::string>{}(name); }
  static ToldRoute of(const wire::RouteEntry& e) { return {e.incarnation, hash(e.name), e.hops}; }
};

std::string endpointText(const tcp::endpoint& e) {
  return e.address().to_string() + ":" + std::to_string(e.port());
}

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

class Network::Impl {
 public:
  class Link;
  struct Route {
    int hops = 0;
    PeisId nextHop = 0;
    std::uint64_t incarnation = 0;
    std::string name;
    bool operator==(const Route&) const = default;
  };
  struct BeaconPeer {
    asio::ip::address address;
    std::uint16_t port = 0;
    std::uint64_t incarnation = 0;
    SteadyClock::time_point lastSeen;
  };

  Impl(asio::io_context& io, NetworkConfig config, PeisId self, std::uint64_t incarnation,
       Events events)
      : io_(io),
        config_(std::move(config)),
        self_(self),
        incarnation_(incarnation),
        events_(std::move(events)),
        acceptor_(io),
        udp_(io),
        beaconTimer_(io),
        pingTimer_(io),
        redialTimer_(io),
        dialTimer_(io),
        acceptRetry_(io),
        explicitLinks_(config_.connect.size()) {}

  void start();
  void stop();
  bool send(wire::RoutedMessage message);
  bool sendUpdate(PeisId destination, std::uint64_t incarnation,
                  const std::shared_ptr<const Tuple>& tuple);
  bool sendFrames(PeisId destination, std::string_view frames, std::uint32_t count);
  std::vector<PeerInfo> peers() const;
  std::vector<LinkInfo> links() const;

  // Called by links.
  void onFrame(const std::shared_ptr<Link>& link, std::string_view frame);
  // A routed frame whose data is over this PEIS's limit (its whole frame or
  // its first kOversizeHeadBytes): answered, not dropped (protocol.md §2.1).
  // False when it is not one (malformed).
  bool answerOversize(const std::shared_ptr<Link>& link, std::string_view head);
  void onClosed(const std::shared_ptr<Link>& link, const std::string& reason);
  // A link finished a write; `backlog` bytes are still queued on it.
  void onWritten(std::size_t backlog);
  bool congested();
  bool congestedSignalled_ = false;
  std::uint16_t listenPort() const {
    boost::system::error_code ec;
    const auto endpoint = acceptor_.local_endpoint(ec);
    return ec ? 0 : endpoint.port();
  }
  std::size_t maxFrameBytes() const { return config_.maxDataBytes + wire::kMaxFrameOverhead; }

  asio::io_context& io_;
  NetworkConfig config_;
  PeisId self_;
  std::uint64_t incarnation_;
  Events events_;
  Counters counters_;
  bool stopped_ = false;

 private:
  void accept();
  void dial(const std::string& host, std::uint16_t port, int explicitIndex);
  void addLink(tcp::socket socket, bool outbound, int explicitIndex, PeisId dialTarget = 0);
  void onHello(const std::shared_ptr<Link>& link, const wire::Hello& hello);
  void onMalformed(const std::shared_ptr<Link>& link, const std::string& error);
  void onRouted(const std::shared_ptr<Link>& link, std::string_view frame);
  void deliverOrForward(std::string_view frame, wire::RoutedMessage&& message);
  void forwardFrame(std::string_view frame, const wire::Envelope& envelope);
  std::string decodeError_;
  std::uint64_t routesEpoch_ = 1;  // bumped whenever routes, links or adverts change
  void retryHeld();
  struct Held {
    std::string frame;
    wire::RoutedMessage message;
    SteadyClock::time_point arrived;
  };
  std::deque<Held> held_;
  // Answers to frames over the data limit (answerOversize) for a PEIS with
  // no route yet (its first frames can be faster than its route, as above):
  // sent once it has one, dropped after kHoldFor.
  std::deque<std::pair<wire::RoutedMessage, SteadyClock::time_point>> heldAnswers_;
  // Messages for this PEIS, handed over together once a read is parsed.
  std::vector<wire::RoutedMessage> inbox_;
  // Two buffers take turns so a stream of reads allocates no new vector.
  std::vector<wire::RoutedMessage> spareInbox_;
  void flushInbox() {
    if (inbox_.empty()) return;
    std::vector<wire::RoutedMessage> messages;
    messages.swap(inbox_);
    inbox_.swap(spareInbox_);
    if (events_.onMessages) events_.onMessages(std::move(messages));
    messages.clear();  // the handler took the messages; keep the buffer
    if (spareInbox_.capacity() < messages.capacity()) spareInbox_.swap(messages);
  }
  void collision(std::uint64_t otherIncarnation);
  // Re-evaluates the routes of the ids in dirty_ (the only ones whose
  // candidates changed since the last time), fires the events.
  void recompute();
  // An advert entry from `from` changed: its id needs re-evaluating only if
  // the entry could change its route (no route yet, a better one, or one
  // from the current next hop).
  void advertChanged(PeisId from, PeisId id, std::uint8_t hops);
  void scheduleAdvert();
  void scheduleRecompute();
  struct Throttle {
    explicit Throttle(asio::io_context& io) : timer(io) {}
    asio::steady_timer timer;
    bool scheduled = false;
    SteadyClock::time_point last;
  };
  void throttle(Throttle& t, std::chrono::milliseconds interval, void (Impl::*work)());
  // Sends each linked PEIS what changed in its view of the routes.
  void advertise();
  // Sends a link the whole table (its first advert).
  void advertiseAll(Link& link);
  std::shared_ptr<Link> linkTo(PeisId peer) const;
  Link* findLink(PeisId peer) const;  // linkTo without the reference count
  // `relayedFrom`: the source of a frame this PEIS relays (0: its own).
  bool forward(PeisId destination, std::string frame, PeisId relayedFrom = 0);
  // Tells `link` our route to `id` now, unless it knows it or the route goes
  // through it.
  void tellRoute(Link& link, PeisId id);
  void beaconLoop();
  void sendBeacon(const udp::endpoint& to, bool wantsAnswer);
  void receiveBeacons();
  void onBeacon(const Beacon& beacon, const udp::endpoint& from);
  void evaluateDials();
  // Evaluates dials once beacons have been quiet for a moment (bounded), so
  // PEIS starting together do not link to every target they pass through.
  void scheduleDials();
  void pruneLinks();
  // Runs pruneLinks once the membership and the links have been settled for
  // kLinkGrace (not only at the next beacon, which may be 8 s away).
  void schedulePrune();
  void armPrune(SteadyClock::time_point at);
  asio::steady_timer pruneTimer_{io_};
  bool pruneArmed_ = false;
  void armBeacon(SteadyClock::time_point at);
  void membershipChanged(SteadyClock::time_point now);
  std::vector<PeisId> overlayIds() const;
  void pingLoop();
  void redialLoop();
  wire::Hello hello() const;

  tcp::acceptor acceptor_;
  udp::socket udp_;
  udp::endpoint beaconFrom_;
  std::array<char, 512> beaconBuffer_{};
  asio::steady_timer beaconTimer_, pingTimer_, redialTimer_, dialTimer_, acceptRetry_;
  bool dialsPending_ = false;
  Throttle recomputeThrottle_{io_}, advertThrottle_{io_};
  SteadyClock::time_point membershipChanged_;
  std::chrono::milliseconds beaconInterval_{0};  // the current beacon period
  // Distinct PEIS whose broadcast beacons we heard since our last one (up to
  // the quorum).
  std::vector<PeisId> beaconsHeardFrom_;
  SteadyClock::time_point beaconDue_;
  SteadyClock::time_point dialsFirstAsked_;
  std::vector<std::shared_ptr<Link>> links_;
  std::vector<std::weak_ptr<Link>> explicitLinks_;
  std::map<PeisId, Route> routes_;
  // What each linked PEIS told us it can reach (applied as deltas).
  std::map<PeisId, boost::container::flat_map<PeisId, wire::RouteEntry>> adverts_;
  std::set<PeisId> dirty_;           // ids whose route recompute() must re-evaluate
  std::set<PeisId> advertDirty_;     // ids whose route changed since the last advert
  std::uint64_t collisionSeen_ = 0;  // a neighbour advertised our id with another incarnation
  std::map<PeisId, BeaconPeer> beaconPeers_;
  std::set<PeisId> dialing_;
};

class Network::Impl::Link : public std::enable_shared_from_this<Link> {
 public:
  Link(Impl& net, tcp::socket socket, bool outbound, int explicitIndex)
      : net_(net), socket_(std::move(socket)), outbound_(outbound), explicitIndex_(explicitIndex) {
    boost::system::error_code ec;
    socket_.set_option(tcp::no_delay(true), ec);
    const auto remote = socket_.remote_endpoint(ec);
    remote_ = ec ? std::string("?") : endpointText(remote);
    lastHeard_ = SteadyClock::now();
  }

  void start(const wire::Hello& hello) {
    std::string frame;
    wire::encode(wire::LinkMessage{hello}, frame);
    sendFrame(frame);
    read();
  }

  void sendFrame(std::string_view frame) {
    if (closed_) return;
    enqueue(frame);
    write();
  }

  // Tuple updates are plain frames here; the Kernel coalesces them before
  // they reach a link, when the links are congested (see congested()). The
  // frame is encoded straight into the write queue; the data of a big tuple
  // is written from the tuple itself, which the queue keeps alive.
  void sendUpdate(const wire::Envelope& envelope, std::uint64_t incarnation,
                  const std::shared_ptr<const Tuple>& tuple) {
    if (closed_) return;
    const auto bytes = wire::tupleUpdateFrameBytes(*tuple);
    if (tuple->data.size() >= kZeroCopyBytes) {
      auto& chunk = chunks_.emplace_back();
      wire::encodeTupleUpdate(envelope, incarnation, *tuple, chunk.bytes, wire::TupleData::Omit);
      chunk.tail = tuple;
    } else {
      wire::encodeTupleUpdate(envelope, incarnation, *tuple, appendable(bytes));
    }
    queued_ += bytes;
    ++net_.counters_.framesOut;
    write();
  }

  // Queues whole frames encoded elsewhere (copied into the write buffer,
  // whose memory the link reuses).
  void sendBytes(std::string_view bytes, std::uint32_t frames) {
    if (closed_ || bytes.empty()) return;
    queued_ += bytes.size();
    net_.counters_.framesOut += frames;
    appendable(bytes.size()).append(bytes);
    write();
  }

  void close(const std::string& reason) {
    if (closed_) return;
    closed_ = true;
    boost::system::error_code ec;
    socket_.shutdown(tcp::socket::shutdown_both, ec);
    socket_.close(ec);
    net_.onClosed(shared_from_this(), reason);
  }

  // Sends what is queued, then closes.
  void closeAfterFlush(const std::string& reason) {
    closeReason_ = reason;
    if (!writing_) close(reason);
  }

  std::size_t backlog() const { return inFlight_ + queued_; }
  // Part of a frame has arrived and the rest has not (a big frame in transit).
  bool midFrame() const { return inEnd_ > inPos_ || skip_ > 0; }
  bool bytesWaiting() {
    boost::system::error_code ec;
    return socket_.available(ec) > 0 && !ec;
  }

  Impl& net_;
  tcp::socket socket_;
  bool outbound_;
  int explicitIndex_;
  std::string remote_;
  bool established_ = false;
  wire::Hello peer_;
  SteadyClock::time_point lastHeard_;
  SteadyClock::time_point lastSent_;
  SteadyClock::time_point establishedAt_;
  // The routes this peer last heard from us, compactly (a name by its hash):
  // a PEIS among 200 keeps one per route per link.
  boost::container::flat_map<PeisId, ToldRoute> told_;
  bool toldAll_ = false;  // it got our whole table once
  int malformed_ = 0;
  bool closed_ = false;
  // The last source whose frames passed onRouted's checks on this link, and
  // the routes epoch they were checked in.
  PeisId checkedSource_ = 0;
  std::uint64_t checkedEpoch_ = 0;
  PeisId dialTarget_ = 0;  // the beacon peer this link was dialled for

 private:
  // Frames wait in chunks of about kWriteChunk bytes, so the backlog drains
  // (and coalescing ends) gradually while a slow reader catches up.
  void enqueue(std::string_view frame) {
    appendable(frame.size()).append(frame);
    queued_ += frame.size();
    ++net_.counters_.framesOut;
  }

  // The chunk to append `bytes` of frames to: the last one, unless it is
  // full or ends in a tuple's data. A chunk starts small (an idle link's
  // pings cost little memory) and doubles while a stream fills it.
  std::string& appendable(std::size_t bytes) {
    if (chunks_.empty() || chunks_.back().tail || chunks_.back().bytes.size() >= kWriteChunk) {
      chunks_.emplace_back().bytes = std::move(spareChunk_);
      spareChunk_ = std::string();
    }
    auto& chunk = chunks_.back().bytes;
    if (chunk.capacity() < chunk.size() + bytes) {
      chunk.reserve(std::max({chunk.size() + bytes, 2 * chunk.capacity(), kFirstChunkBytes}));
    }
    return chunk;
  }

  // Keeps the memory of one written chunk for the next (a stream then
  // allocates no write buffers); a huge one is let go.
  void keepSpareChunk() {
    for (auto& chunk : outChunks_) {
      if (spareChunk_.capacity() >= kWriteChunk) return;
      if (chunk.bytes.capacity() > 2 * kWriteChunk) continue;
      chunk.bytes.clear();
      spareChunk_ = std::move(chunk.bytes);
    }
  }

  // Writes the queued chunks, several in one gathered write.
  void write() {
    if (writing_ || closed_) return;
    std::size_t bytes = 0;
    while (!chunks_.empty() && outChunks_.size() < kGatherChunks && bytes < kGatherBytes) {
      if (chunks_.front().size() > 0) {
        bytes += chunks_.front().size();
        outChunks_.push_back(std::move(chunks_.front()));
      }
      chunks_.pop_front();
    }
    if (outChunks_.empty()) return;
    queued_ -= bytes;
    inFlight_ = bytes;
    outBuffers_.clear();
    for (const auto& chunk : outChunks_) {
      outBuffers_.emplace_back(asio::buffer(chunk.bytes));
      if (chunk.tail) outBuffers_.emplace_back(asio::buffer(chunk.tail->data));
    }
    writing_ = true;
    lastSent_ = SteadyClock::now();  // what is queued goes out now
    asio::async_write(
        socket_, outBuffers_,
        [self = shared_from_this()](const boost::system::error_code& ec, std::size_t) {
          self->writing_ = false;
          self->keepSpareChunk();
          self->outChunks_.clear();
          self->inFlight_ = 0;
          if (ec) return self->close("write failed: " + ec.message());
          if (!self->closeReason_.empty() && self->chunks_.empty()) {
            return self->close(self->closeReason_);
          }
          self->write();
          self->net_.onWritten(self->backlog());
        });
  }

  // The socket reads straight into in_ (no intermediate buffer): the bytes
  // [inPos_, inEnd_) are received and not parsed yet.
  void read() {
    if (closed_) return;
    makeReadRoom();
    socket_.async_read_some(
        asio::buffer(in_.get() + inEnd_, inCapacity_ - inEnd_),
        [self = shared_from_this()](const boost::system::error_code& ec, std::size_t n) {
          if (ec) {
            return self->close(ec == asio::error::eof ? "closed by peer" : ec.message());
          }
          self->lastHeard_ = SteadyClock::now();
          if (n == self->inCapacity_ - self->inEnd_) {  // filled: more is likely waiting
            self->readRoom_ = std::min(2 * self->readRoom_, kMaxReadRoom);
          }
          self->inEnd_ += n;
          self->parse();
          self->net_.flushInbox();
          self->read();
        });
  }

  // Room after inEnd_ for readRoom_ bytes, or for the rest of a frame whose
  // length is known to be bigger, so a big frame arrives in place.
  void makeReadRoom() {
    const std::size_t pending = inEnd_ - inPos_;
    std::size_t want = readRoom_;
    if (pending >= wire::kFrameHeaderBytes) {
      const auto frame =
          wire::kFrameHeaderBytes + wire::frameLength(std::string_view(in_.get() + inPos_, 4));
      // (parse() has closed the link on an impossible length already)
      if (frame > pending && frame <= net_.maxFrameBytes() + wire::kFrameHeaderBytes) {
        want = std::max(want, frame - pending);
      }
    }
    if (inCapacity_ - inEnd_ >= want) return;
    if (inPos_ > 0) {  // move the partial frame to the front
      std::memmove(in_.get(), in_.get() + inPos_, pending);
      inPos_ = 0;
      inEnd_ = pending;
    }
    if (inCapacity_ - inEnd_ < want) {
      // Not value-initialised: only the bytes the socket writes get touched
      // (an idle link costs no resident memory for its buffer).
      std::unique_ptr<char[]> bigger(new char[inEnd_ + want]);
      if (inEnd_ > 0) std::memcpy(bigger.get(), in_.get(), inEnd_);
      in_ = std::move(bigger);
      inCapacity_ = inEnd_ + want;
    }
  }

  void parse() {
    while (!closed_) {
      const std::size_t available = inEnd_ - inPos_;
      if (skip_ > 0) {  // the rest of an oversized frame, already answered
        const auto n = std::min(skip_, available);
        inPos_ += n;
        skip_ -= n;
        if (skip_ > 0) break;
        continue;
      }
      if (available < wire::kFrameHeaderBytes) break;
      const auto length = wire::frameLength(std::string_view(in_.get() + inPos_, available));
      if (length > net_.maxFrameBytes() && length <= wire::kLargestFrameBytes) {
        // Over this PEIS's limit, not the protocol's: answer it from its head.
        const auto head = std::min<std::size_t>(length, wire::kOversizeHeadBytes);
        if (available < wire::kFrameHeaderBytes + head) break;
        const auto frame = std::string_view(in_.get() + inPos_ + wire::kFrameHeaderBytes, head);
        inPos_ += wire::kFrameHeaderBytes + head;
        skip_ = length - head;
        if (net_.answerOversize(shared_from_this(), frame)) continue;
      }
      if (length == 0 || length > net_.maxFrameBytes()) {
        ++net_.counters_.malformedFrames;
        ++net_.counters_.garbagePeersDisconnected;
        return close("frame length " + std::to_string(length) + " is impossible: garbage");
      }
      if (available < wire::kFrameHeaderBytes + length) break;
      const auto frame = std::string_view(in_.get() + inPos_ + wire::kFrameHeaderBytes, length);
      inPos_ += wire::kFrameHeaderBytes + length;
      net_.onFrame(shared_from_this(), frame);
    }
    if (inPos_ == inEnd_) {
      inPos_ = inEnd_ = 0;
      if (inCapacity_ > (1u << 20)) {  // after a huge frame
        in_.reset();
        inCapacity_ = 0;
      }
    }
  }

  std::unique_ptr<char[]> in_;
  std::size_t inCapacity_ = 0;
  std::size_t readRoom_ = kFirstReadRoom;
  std::size_t inPos_ = 0, inEnd_ = 0;
  std::size_t skip_ = 0;  // bytes of an oversized frame still to be skipped
  // Frames waiting to be written: bytes, then (when set) a tuple's data,
  // which is the end of the frame those bytes begin.
  struct Chunk {
    std::string bytes;
    std::shared_ptr<const Tuple> tail;
    std::size_t size() const { return bytes.size() + (tail ? tail->data.size() : 0); }
  };
  std::vector<Chunk> outChunks_;  // being written
  std::string spareChunk_;        // the memory of a written chunk, for the next
  std::vector<asio::const_buffer> outBuffers_;
  std::size_t inFlight_ = 0;
  std::deque<Chunk> chunks_;
  std::size_t queued_ = 0;
  bool writing_ = false;
  std::string closeReason_;
};

void Network::Impl::onWritten(std::size_t backlog) {
  if (congestedSignalled_ && backlog < config_.coalesceAboveBytes / 2 && !congested()) {
    congestedSignalled_ = false;
    if (events_.onWritable) events_.onWritable();
  }
}

bool Network::Impl::congested() {
  for (const auto& link : links_) {
    if (link->backlog() > config_.coalesceAboveBytes) {
      congestedSignalled_ = true;
      return true;
    }
  }
  return false;
}

wire::Hello Network::Impl::hello() const {
  wire::Hello h;
  h.ecology = config_.ecology;
  h.id = self_;
  h.incarnation = incarnation_;
  h.name = config_.name;
  h.listenPort = acceptor_.is_open() ? acceptor_.local_endpoint().port() : 0;
  h.capabilities = wire::kCapabilityCoalescing;
  return h;
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
  if (config_.discovery != DiscoveryScope::Off) {
    udp_.open(udp::v4(), ec);
    if (!ec) udp_.set_option(udp::socket::reuse_address(true), ec);
    if (!ec) udp_.set_option(asio::socket_base::broadcast(true), ec);
    if (!ec) udp_.bind(udp::endpoint(udp::v4(), config_.discoveryPort), ec);
    if (ec) {
      log::warn(self_, "discovery off: cannot bind UDP port " +
                           std::to_string(config_.discoveryPort) + ": " + ec.message());
      udp_.close(ec);
    } else {
      receiveBeacons();
      // The configured period until the membership has been stable for a
      // period (from 0, the back-off below would stay at 0: a PEIS alone
      // would beacon without pause).
      beaconInterval_ = config_.beaconPeriod;
      membershipChanged_ = SteadyClock::now();
      beaconLoop();
    }
  }
  for (std::size_t i = 0; i < config_.connect.size(); ++i) {
    const auto [host, port] = parseHostPort(config_.connect[i]);
    dial(host, port, static_cast<int>(i));
  }
  routes_[self_] = Route{0, self_, incarnation_, config_.name};
  pingLoop();
  redialLoop();
}

void Network::Impl::stop() {
  stopped_ = true;
  boost::system::error_code ec;
  acceptor_.close(ec);
  udp_.close(ec);
  beaconTimer_.cancel();
  pingTimer_.cancel();
  advertThrottle_.timer.cancel();
  redialTimer_.cancel();
  dialTimer_.cancel();
  recomputeThrottle_.timer.cancel();
  pruneTimer_.cancel();
  acceptRetry_.cancel();
  auto links = links_;
  for (auto& link : links) link->close("shutting down");
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
  auto link = std::make_shared<Link>(*this, std::move(socket), outbound, explicitIndex);
  link->dialTarget_ = dialTarget;
  links_.push_back(link);
  if (explicitIndex >= 0) explicitLinks_[static_cast<std::size_t>(explicitIndex)] = link;
  link->start(hello());
}

void Network::Impl::onClosed(const std::shared_ptr<Link>& link, const std::string& reason) {
  links_.erase(std::remove(links_.begin(), links_.end(), link), links_.end());
  if (link->dialTarget_ != 0) dialing_.erase(link->dialTarget_);
  if (link->established_) {
    ++routesEpoch_;  // sources checked on other links may now be judged otherwise
    dialing_.erase(link->peer_.id);
    log::info(self_, "link to PEIS " + std::to_string(link->peer_.id) + " (" + link->remote_ +
                         ") closed: " + reason);
    const PeisId peer = link->peer_.id;
    if (!linkTo(peer)) {
      adverts_.erase(peer);
      dirty_.insert(peer);
      for (const auto& [id, route] : routes_) {
        if (route.nextHop == peer && route.hops > 0) dirty_.insert(id);
      }
    }
    recompute();
  } else {
    log::debug(self_, "link " + link->remote_ + " closed before the handshake: " + reason);
  }
}

void Network::Impl::onMalformed(const std::shared_ptr<Link>& link, const std::string& error) {
  ++counters_.malformedFrames;
  log::warn(self_, "dropped a malformed frame from " + link->remote_ + ": " + error);
  if (++link->malformed_ >= config_.maxMalformedFrames || !link->established_) {
    ++counters_.garbagePeersDisconnected;
    link->close("sent garbage");
  }
}

void Network::Impl::onFrame(const std::shared_ptr<Link>& link, std::string_view frame) {
  ++counters_.framesIn;
  if (wire::isRoutedFrame(frame)) {
    // Decoded straight into the inbox; onRouted takes it out again unless
    // it is for this PEIS.
    auto& message = inbox_.emplace_back();
    if (!wire::decodeRouted(frame, config_.maxDataBytes, message, decodeError_)) {
      inbox_.pop_back();
      if (answerOversize(link, frame)) return;
      return onMalformed(link, decodeError_);
    }
    if (!link->established_) {
      inbox_.pop_back();
      ++counters_.garbagePeersDisconnected;
      return link->close("routed message before the handshake");
    }
    return onRouted(link, frame);
  }
  auto result = wire::decode(frame, config_.maxDataBytes);
  if (!result.message) return onMalformed(link, result.error);
  auto& message = std::get<wire::LinkMessage>(*result.message);
  if (auto* hello = std::get_if<wire::Hello>(&message)) return onHello(link, *hello);
  if (!link->established_) {
    ++counters_.garbagePeersDisconnected;
    return link->close("no handshake");
  }
  if (auto* ping = std::get_if<wire::Ping>(&message)) {
    std::string out;
    wire::encode(wire::LinkMessage{wire::Pong{ping->nonce}}, out);
    link->sendFrame(out);
  } else if (auto* routes = std::get_if<wire::Routes>(&message)) {
    ++routesEpoch_;
    const PeisId from = link->peer_.id;
    auto& known = adverts_[from];
    for (auto& entry : routes->entries) {
      if (entry.id == self_) {
        // Its own entry (0 hops) naming our id: another PEIS holds it.
        if (entry.hops == 0 && entry.incarnation != incarnation_) {
          collisionSeen_ = entry.incarnation;
        }
        continue;
      }
      const auto id = entry.id;
      const auto hops = entry.hops;
      if (hops == kWithdrawn) {
        if (known.erase(id) == 0) continue;
      } else {
        known[id] = std::move(entry);
      }
      advertChanged(from, id, hops);
    }
    if (collisionSeen_ != 0 || !dirty_.empty()) {
      scheduleRecompute();  // adverts arrive in bursts: recompute once per burst
    }
  } else if (auto* taken = std::get_if<wire::IdTaken>(&message)) {
    if (taken->id == self_ && taken->incarnation == incarnation_) collision(0);
  }
}

bool Network::Impl::answerOversize(const std::shared_ptr<Link>& link, std::string_view head) {
  auto oversize = wire::decodeOversize(head, config_.maxDataBytes);
  if (!oversize || !link->established_) return false;
  auto answer = wire::answerOversize(*oversize, self_, config_.maxDataBytes);
  if (answer.envelope.destination == self_) {
    inbox_.push_back(std::move(answer));  // a TupleWithheld in place of the owner's update
  } else if (routes_.count(answer.envelope.destination)) {
    forward(answer.envelope.destination, wire::encodeFrame(answer));
  } else {
    heldAnswers_.emplace_back(std::move(answer), SteadyClock::now());
  }
  return true;
}

void Network::Impl::onHello(const std::shared_ptr<Link>& link, const wire::Hello& hello) {
  if (link->established_) {
    ++link->malformed_;
    return;
  }
  if (hello.version != wire::kVersion) {
    return link->close("protocol version " + std::to_string(hello.version) + " is not " +
                       std::to_string(wire::kVersion));
  }
  if (hello.ecology != config_.ecology) {
    ++counters_.foreignEcologyRejected;
    return link->close("peer belongs to ecology '" + hello.ecology + "'");
  }
  if (hello.id == self_) {
    if (hello.incarnation == incarnation_) return link->close("connected to myself");
    ++counters_.idCollisions;
    if (incarnation_ < hello.incarnation) {
      std::string out;
      wire::encode(wire::LinkMessage{wire::IdTaken{hello.id, hello.incarnation}}, out);
      link->sendFrame(out);
      return link->closeAfterFlush("id " + std::to_string(self_) + " is mine");
    }
    link->close("id collision");
    return collision(hello.incarnation);
  }
  if (auto existing = linkTo(hello.id)) {
    if (existing->peer_.incarnation != hello.incarnation) {
      ++counters_.idCollisions;
      return link->close("PEIS " + std::to_string(hello.id) +
                         " is already linked with another incarnation");
    }
    // Keep the link the lower id dialled, so both ends keep the same one.
    const bool keepNew = (self_ < hello.id) == link->outbound_;
    if (!keepNew || existing->outbound_ == link->outbound_) {
      return link->close("duplicate link to PEIS " + std::to_string(hello.id));
    }
    existing->established_ = false;
    existing->close("replaced by a new link");
  }
  link->established_ = true;
  ++routesEpoch_;
  link->establishedAt_ = SteadyClock::now();
  if (link->explicitIndex_ < 0) schedulePrune();
  link->peer_ = hello;
  dialing_.erase(hello.id);
  log::info(self_, "linked to PEIS " + std::to_string(hello.id) + " '" + hello.name + "' at " +
                       link->remote_ + (link->outbound_ ? " (dialled)" : " (accepted)"));
  dirty_.insert(hello.id);
  recompute();
  // The new link gets the whole table now; the others hear of the new route
  // with the next advert.
  if (!link->closed_) advertiseAll(*link);
}

void Network::Impl::collision(std::uint64_t otherIncarnation) {
  if (otherIncarnation != 0 && otherIncarnation > incarnation_) return;  // the other re-picks
  const PeisId old = self_;
  self_ = events_.repickId ? events_.repickId() : old;
  log::warn(old, "id " + std::to_string(old) + " is held by a PEIS that started earlier; now " +
                     std::to_string(self_));
  routes_.clear();
  adverts_.clear();
  ++routesEpoch_;
  dirty_.clear();
  advertDirty_.clear();
  collisionSeen_ = 0;
  auto links = links_;
  for (auto& l : links) l->close("re-picked my id");
  routes_[self_] = Route{0, self_, incarnation_, config_.name};
  if (udp_.is_open())
    sendBeacon(udp::endpoint(asio::ip::make_address_v4("127.255.255.255"), config_.discoveryPort),
               true);
}

// The message is inbox_.back(): it stays there only when it is for this PEIS.
void Network::Impl::onRouted(const std::shared_ptr<Link>& link, std::string_view frame) {
  const auto envelope = inbox_.back().envelope;
  auto drop = [this] { inbox_.pop_back(); };
  if (envelope.source == self_) {  // our own frame came back: a transient loop
    ++counters_.unroutable;
    return drop();
  }
  // The checks below depend only on the source, the link and the routes: a
  // stream of frames from one source skips them while nothing changed.
  if (link->checkedSource_ != envelope.source || link->checkedEpoch_ != routesEpoch_) {
    // Its route may sit in an advert whose recompute is still pending.
    if (!routes_.count(envelope.source) && recomputeThrottle_.scheduled) {
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
    const auto direct = linkTo(envelope.source);
    const auto relay = adverts_.find(link->peer_.id);
    const bool relayed = relay != adverts_.end() && relay->second.count(envelope.source) != 0;
    if (direct && direct != link && !relayed) {
      ++counters_.malformedFrames;
      log::warn(self_, "dropped a frame from " + link->remote_ + " with spoofed source " +
                           std::to_string(envelope.source));
      drop();
      if (++link->malformed_ >= config_.maxMalformedFrames) {
        ++counters_.garbagePeersDisconnected;
        link->close("sent garbage");
      }
      return;
    }
    if (!routes_.count(envelope.source)) {
      // A PEIS we have no route to yet: the adverts naming it travel one hop
      // per advert delay, its first messages can be faster. Hold them briefly.
      if (held_.size() >= kMaxHeldFrames) {
        ++counters_.unroutable;
        return drop();
      }
      held_.push_back(Held{std::string(frame), std::move(inbox_.back()), SteadyClock::now()});
      return drop();
    }
    link->checkedSource_ = envelope.source;
    link->checkedEpoch_ = routesEpoch_;
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
    if (routes_.count(answer.envelope.destination)) {
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
    if (routes_.count(h.message.envelope.source)) {
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

std::shared_ptr<Network::Impl::Link> Network::Impl::linkTo(PeisId peer) const {
  for (const auto& link : links_) {
    if (link->established_ && link->peer_.id == peer) return link;
  }
  return nullptr;
}

Network::Impl::Link* Network::Impl::findLink(PeisId peer) const {
  for (const auto& link : links_) {
    if (link->established_ && link->peer_.id == peer) return link.get();
  }
  return nullptr;
}

bool Network::Impl::forward(PeisId destination, std::string frame, PeisId relayedFrom) {
  auto route = routes_.find(destination);
  if (route == routes_.end() || route->second.hops == 0) {
    ++counters_.unroutable;
    return false;
  }
  auto* link = findLink(route->second.nextHop);
  if (!link) {
    ++counters_.unroutable;
    return false;
  }
  // The next hop takes a frame claiming a linked PEIS's id from another link
  // for spoofed unless that link advertised a route to it: the advert must
  // not lag behind the frames relayed from that PEIS (adverts are batched).
  if (relayedFrom != 0 && link->toldAll_ && !link->told_.count(relayedFrom)) {
    tellRoute(*link, relayedFrom);
  }
  link->sendFrame(frame);
  return true;
}

void Network::Impl::tellRoute(Link& link, PeisId id) {
  const auto route = routes_.find(id);
  if (route == routes_.end()) return;
  const auto& r = route->second;
  if (r.hops > 0 && r.nextHop == link.peer_.id) return;  // split horizon
  wire::RouteEntry entry{id, static_cast<std::uint8_t>(r.hops), r.incarnation, r.name};
  link.told_.insert_or_assign(id, ToldRoute::of(entry));
  wire::Routes one;
  one.entries.push_back(std::move(entry));
  std::string out;
  wire::encode(wire::LinkMessage{one}, out);
  link.sendFrame(out);
}

bool Network::Impl::send(wire::RoutedMessage message) {
  message.envelope.source = self_;
  if (message.envelope.ttl == 0) message.envelope.ttl = wire::kDefaultTtl;
  return forward(message.envelope.destination, wire::encodeFrame(message));
}

bool Network::Impl::sendUpdate(PeisId destination, std::uint64_t incarnation,
                               const std::shared_ptr<const Tuple>& tuple) {
  auto route = routes_.find(destination);
  if (route == routes_.end() || route->second.hops == 0) {
    ++counters_.unroutable;
    return false;
  }
  auto* link = findLink(route->second.nextHop);
  if (!link) {
    ++counters_.unroutable;
    return false;
  }
  link->sendUpdate(wire::Envelope{self_, destination, wire::kDefaultTtl}, incarnation, tuple);
  return true;
}

bool Network::Impl::sendFrames(PeisId destination, std::string_view frames, std::uint32_t count) {
  auto route = routes_.find(destination);
  Link* link =
      route == routes_.end() || route->second.hops == 0 ? nullptr : findLink(route->second.nextHop);
  if (!link) {
    counters_.unroutable += count;
    return false;
  }
  link->sendBytes(frames, count);
  return true;
}

void Network::Impl::advertChanged(PeisId from, PeisId id, std::uint8_t hops) {
  const auto route = routes_.find(id);
  if (route == routes_.end() || route->second.nextHop == from ||
      (hops != kWithdrawn && hops + 1 < route->second.hops)) {
    dirty_.insert(id);
  }
}

// Distance vector: the shortest route over the links and their adverts wins;
// on a tie the current next hop is kept, else the first link offering it.
// Only the dirty ids are evaluated: every other route is unchanged, since
// none of its candidates changed in a way that could move it.
void Network::Impl::recompute() {
  ++routesEpoch_;  // links or adverts changed (or may have): re-check sources
  if (collisionSeen_ != 0) {
    const auto other = collisionSeen_;
    collisionSeen_ = 0;
    ++counters_.idCollisions;
    collision(other);
    return;
  }
  if (dirty_.empty()) return retryHeld();
  struct Neighbour {
    const wire::Hello* peer;
    const boost::container::flat_map<PeisId, wire::RouteEntry>* advert;
  };
  std::vector<Neighbour> neighbours;
  neighbours.reserve(links_.size());
  for (const auto& link : links_) {
    if (!link->established_) continue;
    const auto advert = adverts_.find(link->peer_.id);
    neighbours.push_back(
        Neighbour{&link->peer_, advert == adverts_.end() ? nullptr : &advert->second});
  }
  std::vector<PeisId> up, down;
  bool changed = false;
  const auto dirty = std::move(dirty_);
  dirty_.clear();
  for (const PeisId id : dirty) {
    if (id == self_) continue;
    const auto old = routes_.find(id);
    const PeisId oldNextHop = old == routes_.end() ? 0 : old->second.nextHop;
    int bestHops = kMaxHops + 1;
    PeisId bestNextHop = 0;
    std::uint64_t bestIncarnation = 0;
    const std::string* bestName = nullptr;
    auto offer = [&](int hops, PeisId nextHop, std::uint64_t incarnation, const std::string& name) {
      if (hops > bestHops) return;
      if (hops < bestHops || nextHop == oldNextHop) {
        bestHops = hops;
        bestNextHop = nextHop;
        bestIncarnation = incarnation;
        bestName = &name;
      }
    };
    for (const auto& n : neighbours) {
      if (n.peer->id == id) offer(1, id, n.peer->incarnation, n.peer->name);
      if (!n.advert) continue;
      const auto entry = n.advert->find(id);
      if (entry == n.advert->end() || entry->second.hops + 1 > kMaxHops) continue;
      offer(entry->second.hops + 1, n.peer->id, entry->second.incarnation, entry->second.name);
    }
    if (!bestName) {
      if (old == routes_.end()) continue;
      routes_.erase(old);
      advertDirty_.insert(id);
      down.push_back(id);
      changed = true;
      continue;
    }
    Route best{bestHops, bestNextHop, bestIncarnation, *bestName};
    if (old == routes_.end()) {
      routes_.emplace(id, std::move(best));
      up.push_back(id);
    } else if (old->second != best) {
      if (old->second.incarnation != best.incarnation) up.push_back(id);
      old->second = std::move(best);
    } else {
      continue;
    }
    advertDirty_.insert(id);
    changed = true;
  }
  if (!changed) return retryHeld();
  scheduleAdvert();
  retryHeld();
  for (const PeisId id : down) {
    if (events_.onPeerDown) events_.onPeerDown(id);
  }
  for (const PeisId id : up) {
    const auto route = routes_.find(id);
    if (route == routes_.end() || !events_.onPeerUp) continue;
    const auto& r = route->second;
    events_.onPeerUp(PeerInfo{id, r.name, r.incarnation, r.hops, r.nextHop});
  }
  if (events_.onTopology) events_.onTopology();
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

// Tells each linked PEIS what changed in the routes it should know (split
// horizon: never a route back through itself): only the ids whose route
// changed since the last advert are looked at.
void Network::Impl::advertise() {
  if (advertDirty_.empty()) return;
  const auto changed = std::move(advertDirty_);
  advertDirty_.clear();
  for (const auto& link : links_) {
    if (!link->established_) continue;
    if (!link->toldAll_) {
      advertiseAll(*link);
      continue;
    }
    const PeisId peer = link->peer_.id;
    auto& told = link->told_;
    wire::Routes delta;
    for (const PeisId id : changed) {
      const auto r = routes_.find(id);
      const bool tell = r != routes_.end() && !(r->second.hops > 0 && r->second.nextHop == peer);
      const auto t = told.find(id);
      if (!tell) {
        if (t == told.end()) continue;
        delta.entries.push_back(wire::RouteEntry{id, kWithdrawn, 0, ""});
        told.erase(t);
        continue;
      }
      const auto& route = r->second;
      if (t != told.end() && t->second.hops == route.hops &&
          t->second.incarnation == route.incarnation &&
          t->second.nameHash == ToldRoute::hash(route.name)) {
        continue;
      }
      wire::RouteEntry entry{id, static_cast<std::uint8_t>(route.hops), route.incarnation,
                             route.name};
      if (t == told.end()) {
        told.emplace(id, ToldRoute::of(entry));
      } else {
        t->second = ToldRoute::of(entry);
      }
      delta.entries.push_back(std::move(entry));
    }
    if (delta.entries.empty()) continue;
    std::string out;
    wire::encode(wire::LinkMessage{delta}, out);
    link->sendFrame(out);
  }
}

// A new link's first advert: the whole table, less the routes through it.
void Network::Impl::advertiseAll(Link& link) {
  const PeisId peer = link.peer_.id;
  auto& told = link.told_;
  told.clear();
  link.toldAll_ = true;
  wire::Routes all;
  for (const auto& [id, route] : routes_) {
    if (route.hops > 0 && route.nextHop == peer) continue;  // split horizon
    wire::RouteEntry entry{id, static_cast<std::uint8_t>(route.hops), route.incarnation,
                           route.name};
    told.emplace_hint(told.end(), id, ToldRoute::of(entry));
    all.entries.push_back(std::move(entry));
  }
  if (all.entries.empty()) return;
  std::string out;
  wire::encode(wire::LinkMessage{all}, out);
  link.sendFrame(out);
}

void Network::Impl::pingLoop() {
  pingTimer_.expires_after(config_.pingPeriod);
  pingTimer_.async_wait([this](const boost::system::error_code& ec) {
    if (ec || stopped_) return;
    retryHeld();  // ages out frames whose source never became routable
    const auto now = SteadyClock::now();
    auto links = links_;
    for (auto& link : links) {
      // Bytes waiting in the socket are a sign of life too: after this
      // thread was starved (a busy host), the timer can run before the reads.
      if (now - link->lastHeard_ > config_.deadAfter && !link->bytesWaiting()) {
        link->close("silent for more than " + std::to_string(config_.deadAfter.count()) + " ms");
        continue;
      }
      // Ping only a link we have heard nothing on for a ping period: the
      // Ping tells the peer we live, its Pong tells us. A link busy in
      // one direction costs one Ping a period, an idle one a single
      // exchange (whichever end asks first), not one from each end.
      // So does one that receives a big frame and sends nothing: the peer
      // sending it hears nothing else, and its own Ping waits behind the frame.
      const bool quiet = now - link->lastHeard_ >= config_.pingPeriod ||
                         (link->midFrame() && now - link->lastSent_ >= config_.pingPeriod);
      if (!link->established_ || !quiet) continue;
      std::string out;
      wire::encode(
          wire::LinkMessage{wire::Ping{static_cast<std::uint64_t>(now.time_since_epoch().count())}},
          out);
      link->sendFrame(out);
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

void Network::Impl::beaconLoop() {
  const auto now = SteadyClock::now();
  // Suppression: while the membership is stable, a PEIS that heard the
  // beacons of kBeaconQuorum others since its own last one skips this one.
  // Newcomers and healed partitions are still found through those others;
  // each PEIS then receives a few beacons a period instead of one from every
  // PEIS. After a change nobody skips, so a newcomer hears everybody.
  const bool stable = now - membershipChanged_ >= beaconInterval_;
  if (!stable || beaconsHeardFrom_.size() < kBeaconQuorum) {
    for (const auto& address : broadcastAddresses(config_.discovery)) {
      sendBeacon(udp::endpoint(address, config_.discoveryPort), true);
    }
  } else {
    ++counters_.beaconsSuppressed;
  }
  beaconsHeardFrom_.clear();
  // Forget beacon peers that went quiet.
  // A PEIS still reachable by route is alive even if its beacons are late
  // (a loaded host): forgetting it would reshape the overlay for nothing.
  for (auto it = beaconPeers_.begin(); it != beaconPeers_.end();) {
    const bool quiet = now - it->second.lastSeen > config_.beaconPeriod * 4;
    if (quiet && !routes_.count(it->first)) {
      it = beaconPeers_.erase(it);
      membershipChanged(now);
    } else {
      ++it;
    }
  }
  evaluateDials();
  pruneLinks();
  // While the membership is stable the period doubles, up to
  // kMaxBeaconBackoff times the configured one: N PEIS on a quiet network
  // then cost each other N/8 beacons a second instead of N. A change
  // (below, and in onBeacon) brings the configured period back.
  if (now - membershipChanged_ >= beaconInterval_) {
    beaconInterval_ = std::min(beaconInterval_ * 2, config_.beaconPeriod * kMaxBeaconBackoff);
  } else {
    beaconInterval_ = config_.beaconPeriod;
  }
  armBeacon(now + beaconInterval_);
}

void Network::Impl::armBeacon(SteadyClock::time_point at) {
  beaconDue_ = at;
  beaconTimer_.expires_at(at);
  beaconTimer_.async_wait([this](const boost::system::error_code& ec) {
    if (!ec && !stopped_) beaconLoop();
  });
}

// The membership changed: beacon at the configured period again.
void Network::Impl::membershipChanged(SteadyClock::time_point now) {
  membershipChanged_ = now;
  schedulePrune();
  if (beaconInterval_ == config_.beaconPeriod) return;
  beaconInterval_ = config_.beaconPeriod;
  if (udp_.is_open() && beaconDue_ > now + beaconInterval_) armBeacon(now + beaconInterval_);
}

void Network::Impl::sendBeacon(const udp::endpoint& to, bool wantsAnswer) {
  Beacon beacon{config_.ecology, self_, incarnation_, acceptor_.local_endpoint().port(),
                wantsAnswer};
  auto payload = std::make_shared<std::string>(encodeBeacon(beacon));
  udp_.async_send_to(asio::buffer(*payload), to,
                     [payload](const boost::system::error_code&, std::size_t) {});
}

void Network::Impl::receiveBeacons() {
  udp_.async_receive_from(asio::buffer(beaconBuffer_), beaconFrom_,
                          [this](const boost::system::error_code& ec, std::size_t n) {
                            if (stopped_ || ec == asio::error::operation_aborted) return;
                            if (!ec) {
                              auto beacon = decodeBeacon(std::string_view(beaconBuffer_.data(), n));
                              if (beacon) {
                                onBeacon(*beacon, beaconFrom_);
                              } else {
                                ++counters_.malformedBeacons;
                              }
                            }
                            receiveBeacons();
                          });
}

void Network::Impl::onBeacon(const Beacon& beacon, const udp::endpoint& from) {
  if (beacon.ecology != config_.ecology) return;
  if (beacon.id == self_) {
    if (beacon.incarnation != incarnation_) {
      ++counters_.idCollisions;
      collision(beacon.incarnation);
    }
    return;
  }
  if (beacon.wantsAnswer && beaconsHeardFrom_.size() < kBeaconQuorum &&
      std::find(beaconsHeardFrom_.begin(), beaconsHeardFrom_.end(), beacon.id) ==
          beaconsHeardFrom_.end()) {
    beaconsHeardFrom_.push_back(beacon.id);  // distinct PEIS: one heard twice is one
  }
  auto [it, isNew] = beaconPeers_.try_emplace(beacon.id);
  isNew = isNew || it->second.incarnation != beacon.incarnation;
  if (isNew) membershipChanged(SteadyClock::now());
  it->second = BeaconPeer{from.address(), beacon.port, beacon.incarnation, SteadyClock::now()};
  if (isNew) {
    // Only a PEIS the newcomer should link with answers at once (its
    // fingers, and those whose finger it is): the newcomer learns its
    // overlay neighbours now, the others from their next beacon, which the
    // change brings within a beacon period. N answers to each of N joining
    // PEIS were most of the beacon traffic of a join storm.
    if (beacon.wantsAnswer && overlayWantsSorted(overlayIds(), self_, beacon.id)) {
      sendBeacon(from, false);
    }
    scheduleDials();
  }
}

// The overlay: each PEIS wants links to its fingers (below) and to the PEIS
// whose fingers it is: a connected graph of O(log N) links each. Of every
// wanted pair, only the lower id dials, so no link is doubled.
std::vector<PeisId> Network::Impl::overlayIds() const {
  std::vector<PeisId> ids{self_};
  for (const auto& [id, peer] : beaconPeers_) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

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
  const auto ids = overlayIds();
  for (const PeisId target : overlayPeers(ids, self_)) {
    if (target <= self_ || linkTo(target) || dialing_.count(target)) continue;
    const auto& peer = beaconPeers_[target];
    log::debug(self_, "dialling PEIS " + std::to_string(target) + " (overlay of " +
                          std::to_string(ids.size()) + ")");
    dialing_.insert(target);
    auto socket = std::make_shared<tcp::socket>(io_);
    socket->async_connect(tcp::endpoint(peer.address, peer.port),
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
    auto settled = membershipChanged_;
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
  // Only once the membership has settled, so both ends agree on the overlay.
  if (now - membershipChanged_ < kLinkGrace) return;
  const auto ids = overlayIds();
  auto links = links_;
  for (const auto& link : links) {
    if (!link->established_ || link->explicitIndex_ >= 0) continue;
    const PeisId peer = link->peer_.id;
    if (self_ > peer || !beaconPeers_.count(peer)) continue;
    if (now - link->establishedAt_ < kLinkGrace || overlayWantsSorted(ids, self_, peer)) continue;
    // Never cut a PEIS off: another neighbour must offer a route to it.
    bool alternative = false;
    for (const auto& [neighbour, advert] : adverts_) {
      if (neighbour != peer && linkTo(neighbour) && advert.count(peer)) alternative = true;
    }
    if (alternative) link->close("not needed by the overlay");
  }
}

std::vector<PeerInfo> Network::Impl::peers() const {
  std::vector<PeerInfo> result;
  for (const auto& [id, route] : routes_) {
    result.push_back(PeerInfo{id, route.name, route.incarnation, route.hops, route.nextHop});
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

Network::Network(asio::io_context& io, NetworkConfig config, PeisId self, std::uint64_t incarnation,
                 Events events)
    : impl_(std::make_unique<Impl>(io, std::move(config), self, incarnation, std::move(events))) {}
Network::~Network() = default;
void Network::start() { impl_->start(); }
void Network::stop() { impl_->stop(); }
bool Network::send(wire::RoutedMessage message) { return impl_->send(std::move(message)); }
bool Network::sendUpdate(PeisId destination, std::uint64_t incarnation,
                         const std::shared_ptr<const Tuple>& tuple) {
  return impl_->sendUpdate(destination, incarnation, tuple);
}
bool Network::sendFrames(PeisId destination, std::string_view frames, std::uint32_t count) {
  return impl_->sendFrames(destination, frames, count);
}
bool Network::congested() { return impl_->congested(); }
bool Network::reachable(PeisId id) const {
  for (const auto& peer : impl_->peers()) {
    if (peer.id == id) return true;
  }
  return false;
}
std::vector<PeerInfo> Network::peers() const { return impl_->peers(); }
std::vector<LinkInfo> Network::links() const { return impl_->links(); }
const Counters& Network::counters() const { return impl_->counters_; }
std::uint16_t Network::port() const { return impl_->listenPort(); }
PeisId Network::self() const { return impl_->self_; }

}  // namespace peis::net
