// Link: one TCP connection's reads and writes; see link.h.
#include "net/link.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <cstring>

#include "net/counters.h"

namespace peis::net {
namespace asio = boost::asio;
using asio::ip::tcp;

namespace {

// A link reads at most readRoom_ bytes at a time: 4 KiB at first (an idle
// link's buffer stays small), doubling up to 32 KiB while reads fill it
// (64 KiB reads measured slower: a read's tuples then outgrow the caches).
constexpr std::size_t kFirstReadRoom = 4 * 1024;
constexpr std::size_t kMaxReadRoom = 32 * 1024;
// Frames wait in chunks of about kWriteChunk bytes, so the backlog drains
// gradually while a slow reader catches up.
constexpr std::size_t kWriteChunk = 256 * 1024;
constexpr std::size_t kFirstChunkBytes = 4 * 1024;  // a new write chunk's first memory
constexpr std::size_t kGatherChunks = 16;           // chunks per gathered write, at most
constexpr std::size_t kGatherBytes = 1024 * 1024;

std::string endpointText(const tcp::endpoint& e) {
  return e.address().to_string() + ":" + std::to_string(e.port());
}

}  // namespace

Link::Link(LinkHandler& handler, Counters& counters, std::size_t maxFrameBytes, tcp::socket socket,
           bool outbound, int explicitIndex)
    : outbound_(outbound),
      explicitIndex_(explicitIndex),
      handler_(handler),
      counters_(counters),
      maxFrameBytes_(maxFrameBytes),
      socket_(std::move(socket)),
      readRoom_(kFirstReadRoom) {
  boost::system::error_code ec;
  socket_.set_option(tcp::no_delay(true), ec);
  const auto remote = socket_.remote_endpoint(ec);
  remote_ = ec ? std::string("?") : endpointText(remote);
  lastHeard_ = SteadyClock::now();
}

void Link::start(const wire::Hello& hello) {
  std::string frame;
  wire::encode(wire::LinkMessage{hello}, frame);
  sendFrame(frame);
  read();
}

void Link::sendFrame(std::string_view frame) {
  MutexLock lock(writeMu_);
  if (writeClosed_) return;
  appendable(frame.size()).append(frame);
  queued_ += frame.size();
  ++counters_.framesOut;
  write();
}

void Link::sendUpdate(const wire::Envelope& envelope, std::uint64_t incarnation,
                      const std::shared_ptr<const Tuple>& tuple) {
  MutexLock lock(writeMu_);
  if (writeClosed_) return;
  const auto bytes = wire::tupleUpdateFrameBytes(*tuple);
  if (tuple->data.size() >= wire::kZeroCopyDataBytes) {
    auto& chunk = chunks_.emplace_back();
    wire::encodeTupleUpdate(envelope, incarnation, *tuple, chunk.bytes, wire::TupleData::Omit);
    chunk.tail = tuple;
  } else {
    wire::encodeTupleUpdate(envelope, incarnation, *tuple, appendable(bytes));
  }
  queued_ += bytes;
  ++counters_.framesOut;
  write();
}

void Link::sendBytes(std::string_view bytes, std::uint32_t frames) {
  MutexLock lock(writeMu_);
  if (writeClosed_ || bytes.empty()) return;
  queued_ += bytes.size();
  counters_.framesOut += frames;
  appendable(bytes.size()).append(bytes);
  write();
}

bool Link::lockForDirect(std::size_t mostBacklog) {
  if (congested_.load(std::memory_order_relaxed)) return false;
  writeMu_.lock();
  if (!writeClosed_ && inFlight_ + queued_ <= mostBacklog) return true;
  writeMu_.unlock();
  return false;
}

std::size_t Link::sendNow(std::string_view bytes, const std::shared_ptr<const Tuple>& tail,
                          std::uint32_t frames) {
  if (writeClosed_) return 0;
  const std::string_view data = tail ? std::string_view(tail->data) : std::string_view();
  const std::size_t size = bytes.size() + data.size();
  counters_.directFramesOut.fetch_add(frames, std::memory_order_relaxed);
  std::size_t sent = 0;
  if (!writing_ && chunks_.empty()) {
    // Idle: straight to the socket, from this thread (no hand-off to the
    // kernel thread, no wake-up of it). Never blocks.
    iovec parts[2] = {{const_cast<char*>(bytes.data()), bytes.size()},
                      {const_cast<char*>(data.data()), data.size()}};
    msghdr message{};
    message.msg_iov = parts;
    message.msg_iovlen = data.empty() ? 1 : 2;
    const auto n = ::sendmsg(socket_.native_handle(), &message, MSG_DONTWAIT | MSG_NOSIGNAL);
    lastSent_ = SteadyClock::now();
    // An error is left to the kernel thread's write, which closes the link.
    sent = n > 0 ? static_cast<std::size_t>(n) : 0;
    if (sent == size) return sent;
    // The rest waits, and the kernel thread writes it: nobody else writes
    // meanwhile (writing_), so the bytes stay in order.
    writing_ = true;
    writingSince_ = lastSent_;
    boost::asio::post(socket_.get_executor(), [self = shared_from_this()] { self->resumeWrite(); });
  }
  // Behind what is queued or being written (or the rest of the above).
  if (sent < bytes.size()) {
    appendable(bytes.size() - sent).append(bytes.substr(sent));
    if (tail) chunks_.back().tail = tail;
  } else if (sent < size) {
    appendable(size - sent).append(data.substr(sent - bytes.size()));
  }
  queued_ += size - sent;
  return sent;
}

void Link::resumeWrite() {
  MutexLock lock(writeMu_);
  writing_ = false;
  write();
}

void Link::close(const std::string& reason) {
  if (closed_) return;
  closed_ = true;
  {
    MutexLock lock(writeMu_);  // no direct send is using the socket now, nor will
    writeClosed_ = true;
    boost::system::error_code ec;
    socket_.shutdown(tcp::socket::shutdown_both, ec);
    socket_.close(ec);
  }
  auto self = shared_from_this();  // the handler may drop its reference
  handler_.onClosed(*this, reason);
}

void Link::closeAfterFlush(const std::string& reason) {
  bool idle;
  {
    MutexLock lock(writeMu_);
    closeReason_ = reason;
    idle = !writing_;
  }
  if (idle) close(reason);
}

bool Link::peerAcknowledgesAll() {
  tcp_info info{};
  socklen_t size = sizeof info;
  if (::getsockopt(socket_.native_handle(), IPPROTO_TCP, TCP_INFO, &info, &size) != 0) return false;
  return info.tcpi_unacked == 0;
}

bool Link::bytesWaiting() {
  boost::system::error_code ec;
  return socket_.available(ec) > 0 && !ec;
}

// The chunk to append `bytes` of frames to: the last one, unless it is
// full or ends in a tuple's data. A chunk starts small (an idle link's
// pings cost little memory) and doubles while a stream fills it.
std::string& Link::appendable(std::size_t bytes) {
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
void Link::keepSpareChunk() {
  for (auto& chunk : outChunks_) {
    if (spareChunk_.capacity() >= kWriteChunk) return;
    if (chunk.bytes.capacity() > 2 * kWriteChunk) continue;
    chunk.bytes.clear();
    spareChunk_ = std::move(chunk.bytes);
  }
}

// Writes the queued chunks, several in one gathered write.
void Link::write() {
  if (writing_ || writeClosed_) return;
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
  writingSince_ = lastSent_ = SteadyClock::now();  // what is queued goes out now
  asio::async_write(socket_, outBuffers_,
                    [self = shared_from_this()](const boost::system::error_code& ec, std::size_t) {
                      std::string closeNow;
                      {
                        MutexLock lock(self->writeMu_);
                        self->writing_ = false;
                        self->keepSpareChunk();
                        self->outChunks_.clear();
                        self->inFlight_ = 0;
                        if (ec) {
                          closeNow = "write failed: " + ec.message();
                        } else if (!self->closeReason_.empty() && self->chunks_.empty()) {
                          closeNow = self->closeReason_;
                        } else {
                          self->write();
                        }
                      }
                      if (!closeNow.empty()) return self->close(closeNow);
                      self->handler_.onWritten(*self);
                    });
}

// The socket reads straight into in_ (no intermediate buffer): the bytes
// [inPos_, inEnd_) are received and not parsed yet.
void Link::read() {
  if (closed_) return;
  makeReadRoom();
  socket_.async_read_some(
      asio::buffer(in_.get() + inEnd_, inCapacity_ - inEnd_),
      [self = shared_from_this()](const boost::system::error_code& ec, std::size_t n) {
        if (ec) return self->close(ec == asio::error::eof ? "closed by peer" : ec.message());
        self->lastHeard_ = SteadyClock::now();
        if (n == self->inCapacity_ - self->inEnd_) {  // filled: more is likely waiting
          self->readRoom_ = std::min(2 * self->readRoom_, kMaxReadRoom);
        }
        self->inEnd_ += n;
        self->parse();
        self->handler_.onReadDone(*self);
        self->read();
      });
}

// Room after inEnd_ for readRoom_ bytes, or for the rest of a frame whose
// length is known to be bigger, so a big frame arrives in place.
void Link::makeReadRoom() {
  const std::size_t pending = inEnd_ - inPos_;
  std::size_t want = readRoom_;
  if (pending >= wire::kFrameHeaderBytes) {
    const auto frame =
        wire::kFrameHeaderBytes + wire::frameLength(std::string_view(in_.get() + inPos_, 4));
    // (parse() has closed the link on an impossible length already)
    if (frame > pending && frame <= maxFrameBytes_ + wire::kFrameHeaderBytes) {
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

void Link::parse() {
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
    if (length > maxFrameBytes_ && length <= wire::kLargestFrameBytes) {
      // Over this PEIS's limit, not the protocol's: answer it from its head.
      const auto head = std::min<std::size_t>(length, wire::kOversizeHeadBytes);
      if (available < wire::kFrameHeaderBytes + head) break;
      const auto frame = std::string_view(in_.get() + inPos_ + wire::kFrameHeaderBytes, head);
      inPos_ += wire::kFrameHeaderBytes + head;
      skip_ = length - head;
      if (handler_.onOversize(*this, frame)) continue;
    }
    if (length == 0 || length > maxFrameBytes_) {
      ++counters_.malformedFrames;
      ++counters_.garbagePeersDisconnected;
      return close("frame length " + std::to_string(length) + " is impossible: garbage");
    }
    if (available < wire::kFrameHeaderBytes + length) break;
    const auto frame = std::string_view(in_.get() + inPos_ + wire::kFrameHeaderBytes, length);
    inPos_ += wire::kFrameHeaderBytes + length;
    handler_.onFrame(*this, frame);
  }
  if (inPos_ == inEnd_) {
    inPos_ = inEnd_ = 0;
    if (inCapacity_ > (1u << 20)) {  // after a huge frame
      in_.reset();
      inCapacity_ = 0;
    }
  }
}

}  // namespace peis::net
