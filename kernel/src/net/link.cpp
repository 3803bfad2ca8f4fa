// Link: one TCP connection's reads and writes; see link.h.
#include "net/link.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <algorithm>
#include <array>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <cerrno>
#include <cstring>

#include "net/counters.h"
#include "net/link_security.h"
#include "security/record_cipher.h"

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
// A stream's chunk holds kWriteChunk and the frames that cross it (an
// outbox entry is at most 64 KiB) without growing again.
constexpr std::size_t kChunkSlack = 64 * 1024 + 1024;
// Written chunks kept for the next while a stream writes (1 MiB); a link
// that goes idle lets them go (shrinkIfIdle).
constexpr std::size_t kSpareChunks = 4;
// After this many reads in a row smaller than kFirstReadRoom, with nothing
// left over, the link is idle (pings, a round trip now and then): its read
// buffer and spare write chunk go back to their first sizes, so the links of
// a join (full route adverts fill 32 KiB reads) do not keep that memory.
constexpr int kIdleReads = 8;
constexpr std::size_t kGatherChunks = 16;  // chunks per gathered write, at most
constexpr std::size_t kGatherBytes = 1024 * 1024;
// The end of a block too small for this many bytes of records (or for all
// that is being sealed) is left empty: no record of a few bytes.
constexpr std::size_t kLeastRecordRoom = 1024;

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
  remoteAddress_ = ec ? std::string("?") : remote.address().to_string();
  openedAt_ = lastHeard_ = SteadyClock::now();
}

Link::~Link() = default;

void Link::start(const wire::Hello& hello) {
  std::string frame;
  wire::encode(wire::LinkMessage{hello}, frame);
  ownHello_ = frame.substr(wire::kFrameHeaderBytes);
  sendFrame(frame);
  read();
}

void Link::secure(std::unique_ptr<security::RecordCipher> cipher) {
  MutexLock lock(writeMu_);  // a direct sender reads cipher_ under it
  cipher_ = std::move(cipher);
  securing_ = true;
}

void Link::sendFrame(std::string_view frame) {
  MutexLock lock(writeMu_);
  if (writeClosed_) return;
  ++counters_.framesOut;
  if (cipher_) return sendSealed(frame, nullptr);
  appendable(frame.size()).append(frame);
  queued_ += frame.size();
  write();
}

void Link::sendUpdate(const wire::Envelope& envelope, std::uint64_t incarnation,
                      const std::shared_ptr<const Tuple>& tuple) {
  MutexLock lock(writeMu_);
  if (writeClosed_) return;
  const auto bytes = wire::tupleUpdateFrameBytes(*tuple);
  ++counters_.framesOut;
  if (cipher_) {  // encoded here, sealed from here (a big tuple's data from the tuple)
    const bool big = tuple->data.size() >= wire::kZeroCopyDataBytes;
    plain_.clear();
    wire::encodeTupleUpdate(envelope, incarnation, *tuple, plain_,
                            big ? wire::TupleData::Omit : wire::TupleData::Include);
    return sendSealed(plain_, big ? tuple : nullptr);
  }
  if (tuple->data.size() >= wire::kZeroCopyDataBytes) {
    auto& chunk = chunks_.emplace_back();
    wire::encodeTupleUpdate(envelope, incarnation, *tuple, chunk.bytes, wire::TupleData::Omit);
    chunk.tail = tuple;
  } else {
    wire::encodeTupleUpdate(envelope, incarnation, *tuple, appendable(bytes));
  }
  queued_ += bytes;
  write();
}

void Link::sendBytes(std::string_view bytes, std::uint32_t frames) {
  MutexLock lock(writeMu_);
  if (writeClosed_ || bytes.empty()) return;
  counters_.framesOut += frames;
  if (cipher_) return sendSealed(bytes, nullptr);
  queued_ += bytes.size();
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
  writtenSinceIdle_ += size;
  std::size_t sent = 0;
  if (cipher_) {
    if (!writing_ && chunks_.empty()) return sendSealedNow(bytes, data);
    queueSealed(bytes, tail);  // behind what is queued or being written
    return 0;
  }
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

// A secured link, idle: the frames sealed into records (sealed_ is free:
// no write is under way), and written as sendNow does. If the socket takes
// only part, the rest of the records waits as a sealed chunk, written
// before anything queued after it (and sealed after it): the records'
// numbers stay in the order they go out.
std::size_t Link::sendSealedNow(std::string_view bytes, std::string_view data) {
  using security::RecordCipher;
  sealRoom(RecordCipher::sealedBytes(bytes.size()) +
           (data.empty() ? 0 : RecordCipher::sealedBytes(data.size())));
  sealedBytes_ = cipher_->seal(bytes, sealed_.data());
  if (!data.empty()) sealedBytes_ += cipher_->seal(data, sealed_.data() + sealedBytes_);
  const auto n =
      ::send(socket_.native_handle(), sealed_.data(), sealedBytes_, MSG_DONTWAIT | MSG_NOSIGNAL);
  lastSent_ = SteadyClock::now();
  // An error is left to the kernel thread's write, which closes the link.
  const std::size_t sent = n > 0 ? static_cast<std::size_t>(n) : 0;
  if (sent == sealedBytes_) return bytes.size() + data.size();
  auto& rest = newRecordBlock(sealedBytes_ - sent);
  std::memcpy(rest.records.get(), sealed_.data() + sent, sealedBytes_ - sent);
  rest.recordBytes = sealedBytes_ - sent;
  queued_ += rest.recordBytes;
  writing_ = true;
  writingSince_ = lastSent_;
  boost::asio::post(socket_.get_executor(), [self = shared_from_this()] { self->resumeWrite(); });
  return 0;
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
// pings cost little memory) and doubles while a stream fills it; once one
// has grown (a stream), new chunks take kWriteChunk at once and written ones
// are kept for the next (spareChunks_): a backlog of fresh chunks grown by
// doubling cost the writer a copy of each and a page fault per 4 KiB of
// frames (glibc gave the freed ones back, the next faulted them in again).
std::string& Link::appendable(std::size_t bytes) {
  if (chunks_.empty() || chunks_.back().tail || chunks_.back().records ||
      chunks_.back().bytes.size() >= kWriteChunk) {
    auto& fresh = chunks_.emplace_back().bytes;
    if (!spareChunks_.empty()) {
      fresh = std::move(spareChunks_.back());
      spareChunks_.pop_back();
    }
  }
  auto& chunk = chunks_.back().bytes;
  if (chunk.capacity() < chunk.size() + bytes) {
    chunk.reserve(bigWrites_
                      ? std::max(chunk.size() + bytes, kWriteChunk + kChunkSlack)
                      : std::max({chunk.size() + bytes, 2 * chunk.capacity(), kFirstChunkBytes}));
    if (chunk.capacity() > kFirstChunkBytes) {
      idleWrites_ = false;  // a stream: keep its memory
      bigWrites_ = true;
    }
  }
  return chunk;
}

// Keeps the memory of the written chunks for the next (a stream then
// allocates no write buffers: up to kSpareChunks while it writes big
// chunks, one otherwise), and of a few record blocks; a huge one is let go.
void Link::keepSpareChunk() {
  for (auto& chunk : outChunks_) {
    if (chunk.recordRoom == kRecordBlockBytes && spareRecords_.size() < kSpareRecordBlocks &&
        !idleWrites_) {
      spareRecords_.push_back(std::move(chunk.records));
    }
  }
  const std::size_t keep = bigWrites_ ? kSpareChunks : 1;
  for (auto& chunk : outChunks_) {
    if (spareChunks_.size() >= keep) return;
    if (chunk.recordRoom > 0) continue;  // records: no frames' memory
    if (chunk.bytes.capacity() > 2 * kWriteChunk) continue;
    if (chunk.bytes.capacity() < kFirstChunkBytes) continue;  // nothing worth keeping
    if (idleWrites_ && chunk.bytes.capacity() > kFirstChunkBytes) continue;
    chunk.bytes.clear();
    spareChunks_.push_back(std::move(chunk.bytes));
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
  writtenSinceIdle_ += bytes;
  outBuffers_.clear();
  if (cipher_) {
    sealChunks();
  } else {
    for (const auto& chunk : outChunks_) {
      outBuffers_.emplace_back(asio::buffer(chunk.bytes));
      if (chunk.tail) outBuffers_.emplace_back(asio::buffer(chunk.tail->data));
    }
  }
  startWrite();
}

// A secured link: frames given to the kernel thread (a flush's batch of
// an outbox entry, a frame, a tuple update) are sealed from where they are
// straight into records, not first copied into a chunk to be sealed from
// there when written: one pass over the bytes fewer (a 1 KiB stream's
// writer spent about 0.13 µs an update on that copy). Idle, the records
// are written at once (writeSealed); else they wait, sealed, behind what
// is queued (queueSealed). Either way they are the next ones in order.
// `tail`: a big tuple whose data ends the frame `bytes` begin.
void Link::sendSealed(std::string_view bytes, const std::shared_ptr<const Tuple>& tail) {
  if (!writing_ && chunks_.empty()) {
    return writeSealed(bytes, tail ? std::string_view(tail->data) : std::string_view());
  }
  queueSealed(bytes, tail);
  write();
}

// Seals `bytes` into record blocks at the end of the queue. A big tuple's
// data waits by reference instead, as on an open link (no copy of it
// queued), and is sealed when written (sealChunks), with the frames
// queued after it: records sealed now must not overtake those sealed
// later. So do frames queued before the records were on (only a link's
// first frames can be).
void Link::queueSealed(std::string_view bytes, const std::shared_ptr<const Tuple>& tail) {
  if (tail || (!chunks_.empty() && !chunks_.back().records)) {
    appendable(bytes.size()).append(bytes);
    if (tail) chunks_.back().tail = tail;
    queued_ += bytes.size() + (tail ? tail->data.size() : 0);
    return;
  }
  sealQueued(bytes);
}

void Link::sealQueued(std::string_view plain) {
  using security::RecordCipher;
  while (!plain.empty()) {
    auto* chunk = chunks_.empty() || !chunks_.back().records ? nullptr : &chunks_.back();
    const auto room = chunk ? chunk->recordRoom - chunk->recordBytes : 0;
    if (room < std::min(kLeastRecordRoom, RecordCipher::sealedBytes(plain.size()))) {
      chunk = &newRecordBlock(kRecordBlockBytes);
    }
    const auto n =
        std::min(plain.size(), RecordCipher::plainFitting(chunk->recordRoom - chunk->recordBytes));
    const auto sealed =
        cipher_->seal(plain.substr(0, n), chunk->records.get() + chunk->recordBytes);
    chunk->recordBytes += sealed;
    queued_ += sealed;
    plain.remove_prefix(n);
  }
}

// A new chunk at the end of the queue for `bytes` of records: a block (a
// spare one if there is), or bigger if they need it.
Link::Chunk& Link::newRecordBlock(std::size_t bytes) {
  auto& chunk = chunks_.emplace_back();
  chunk.recordRoom = std::max(bytes, kRecordBlockBytes);
  if (chunk.recordRoom == kRecordBlockBytes && !spareRecords_.empty()) {
    chunk.records = std::move(spareRecords_.back());
    spareRecords_.pop_back();
  } else {
    // Not value-initialised: only the sealing writes its bytes.
    chunk.records.reset(new char[chunk.recordRoom]);
    idleWrites_ = false;  // a busy link: keep its blocks until it is idle again
  }
  return chunk;
}

// A secured link with nothing queued nor being written: the records go
// out at once, from sealed_ (free: no write is under way).
void Link::writeSealed(std::string_view bytes, std::string_view data) {
  using security::RecordCipher;
  sealRoom(RecordCipher::sealedBytes(bytes.size()) +
           (data.empty() ? 0 : RecordCipher::sealedBytes(data.size())));
  sealedBytes_ = cipher_->seal(bytes, sealed_.data());
  if (!data.empty()) sealedBytes_ += cipher_->seal(data, sealed_.data() + sealedBytes_);
  inFlight_ = bytes.size() + data.size();
  writtenSinceIdle_ += inFlight_;
  outBuffers_.clear();
  outBuffers_.emplace_back(asio::buffer(sealed_.data(), sealedBytes_));
  startWrite();
}

// Writes outBuffers_ (the chunks of outChunks_, or the records in sealed_);
// when done, the next queued chunks.
void Link::startWrite() {
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

// A secured link writes the chunks as records (the link-level cipher
// layer, security/record_cipher.h): record blocks as they are, frames
// queued before the records were on sealed now, each piece from where it
// is (a chunk's frames, a big tuple's data) straight into sealed_.
void Link::sealChunks() {
  using security::RecordCipher;
  std::size_t room = 0;
  for (const auto& chunk : outChunks_) {
    if (chunk.records) continue;
    room += RecordCipher::sealedBytes(chunk.bytes.size());
    if (chunk.tail) room += RecordCipher::sealedBytes(chunk.tail->data.size());
  }
  if (room > 0) sealRoom(room);
  sealedBytes_ = 0;
  for (const auto& chunk : outChunks_) {
    if (chunk.records) {
      outBuffers_.emplace_back(asio::buffer(chunk.records.get(), chunk.recordBytes));
      continue;
    }
    const auto from = sealedBytes_;
    if (!chunk.bytes.empty()) sealedBytes_ += cipher_->seal(chunk.bytes, sealed_.data() + from);
    if (chunk.tail && !chunk.tail->data.empty()) {
      sealedBytes_ += cipher_->seal(chunk.tail->data, sealed_.data() + sealedBytes_);
    }
    outBuffers_.emplace_back(asio::buffer(sealed_.data() + from, sealedBytes_ - from));
  }
}

// Room for `bytes` of records in sealed_, which only grows (its bytes are
// written once, by the sealing: no zero-filling pass per write); a huge
// buffer (after a huge value) is let go first.
void Link::sealRoom(std::size_t bytes) {
  if (sealed_.size() > 4 * kGatherBytes && bytes <= kGatherBytes) sealed_ = std::string();
  if (sealed_.size() < bytes) sealed_.resize(std::max(bytes, 2 * sealed_.size()));
}

// The socket reads straight into in_ (no intermediate buffer): the bytes
// [inPos_, inEnd_) are received and not parsed yet. A secured link reads
// into its record buffer instead and opens the records into in_.
void Link::read() {
  if (closed_) return;
  if (cipher_) {
    makeRecordRoom();
    return socket_.receiveDrained(
        std::array<asio::mutable_buffer, 1>{
            asio::buffer(records_.get() + recordsEnd_, recordsCapacity_ - recordsEnd_)},
        drainedWhenShort_,
        [self = shared_from_this()](const boost::system::error_code& ec, std::size_t n) {
          if (ec) return self->close(ec == asio::error::eof ? "closed by peer" : ec.message());
          self->lastHeard_ = SteadyClock::now();
          if (n == self->recordsCapacity_ - self->recordsEnd_ && self->established_) {
            self->readRoom_ = std::min(2 * self->readRoom_, kMaxReadRoom);
          }
          const bool filled = n == self->recordsCapacity_ - self->recordsEnd_;
          self->recordsEnd_ += n;
          if (!self->openRecords()) return;
          self->parse();
          self->noteReadShape(filled);
          self->handler_.onReadDone(*self);
          self->read();
        });
  }
  const auto room = makeReadRoom(readRoom_);
  const auto handler = [self = shared_from_this()](const boost::system::error_code& ec,
                                                   std::size_t n) {
    if (ec) return self->close(ec == asio::error::eof ? "closed by peer" : ec.message());
    self->received(n, self->asked_);
    self->afterRead(n);
  };
  asked_ = room;
  if (placedLeft_ > 0) {
    // The rest of a placed frame into its place, what follows into in_.
    asked_ += placedLeft_;
    return socket_.receiveDrained(
        std::array<asio::mutable_buffer, 2>{asio::buffer(placedAt_, placedLeft_),
                                            asio::buffer(in_.get() + inEnd_, room)},
        drainedWhenShort_, handler);
  }
  if (expectedHead_ > 0 && inEnd_ == 0 && skip_ == 0) {
    // The next frame is expected to be like the last placed one: its head
    // into in_, its data into the place reserved for it, what follows
    // into in_ again (one read for the whole frame). (Not while the rest
    // of an oversized frame is being skipped: those bytes begin no frame.)
    reserved_ = handler_.reservePlace(*this, expectedPlaced_);
    if (reserved_) {
      const auto after = makeReadRoom(expectedHead_ + readRoom_) - expectedHead_;
      asked_ = expectedHead_ + expectedPlaced_ + after;
      return socket_.receiveDrained(
          std::array<asio::mutable_buffer, 3>{asio::buffer(in_.get(), expectedHead_),
                                              asio::buffer(reserved_, expectedPlaced_),
                                              asio::buffer(in_.get() + expectedHead_, after)},
          drainedWhenShort_, handler);
    }
    expectedHead_ = 0;
  }
  socket_.receiveDrained(
      std::array<asio::mutable_buffer, 1>{asio::buffer(in_.get() + inEnd_, room)},
      drainedWhenShort_, handler);
}

// One read of what has arrived, from this thread, never waiting: the rest
// of a placed frame into its place, then into in_. Returns the bytes read:
// 0 when nothing had arrived or the link closed.
std::size_t Link::receive() {
  const auto room = makeReadRoom(readRoom_);
  iovec parts[2];
  int count = 0;
  if (placedLeft_ > 0) parts[count++] = {placedAt_, placedLeft_};
  parts[count++] = {in_.get() + inEnd_, room};
  msghdr message{};
  message.msg_iov = parts;
  message.msg_iovlen = static_cast<std::size_t>(count);
  const auto n = ::recvmsg(socket_.native_handle(), &message, MSG_DONTWAIT);
  if (n > 0) {
    received(static_cast<std::size_t>(n), room + (count == 2 ? placedLeft_ : 0));
    return static_cast<std::size_t>(n);
  }
  filled_ = false;
  if (n == 0) {
    close("closed by peer");
  } else if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
    close(std::strerror(errno));
  }
  return 0;
}

// `n` bytes arrived by a read of at most `asked`: into the placed frame's
// place first (if any), then into in_.
void Link::received(std::size_t n, std::size_t asked) {
  lastHeard_ = SteadyClock::now();
  filled_ = n == asked;
  if (reserved_) return receivedAsExpected(n);
  const auto placed = std::min(n, placedLeft_);
  // Filled: more is likely waiting (a link in its handshake keeps the
  // first, small buffer).
  if (placedLeft_ == 0 && filled_ && established_) {
    readRoom_ = std::min(2 * readRoom_, kMaxReadRoom);
  }
  inEnd_ += n - placed;
  if (placed == 0) return;
  placedAt_ += placed;
  placedLeft_ -= placed;
  if (placedLeft_ == 0) completePlaced();
}

// A read laid out for a frame like the last placed one (read()): if it is
// one, its data is in place already; if not, its bytes go back to where a
// plain read puts them (a copy, as a frame read whole costs) and no frame
// is expected until another is placed.
void Link::receivedAsExpected(std::size_t n) {
  char* const place = std::exchange(reserved_, nullptr);
  const auto head = expectedHead_;
  if (n <= head) {  // only the head's room: as a plain read
    inEnd_ = n;
    return;
  }
  const auto landed = std::min(n - head, expectedPlaced_);
  const auto after = n - head - landed;
  const auto length = wire::frameLength(std::string_view(in_.get(), wire::kFrameHeaderBytes));
  if (wire::kFrameHeaderBytes + length == head + expectedPlaced_ && mayPlace(length) &&
      handler_.placeReserved(
          *this,
          std::string_view(in_.get() + wire::kFrameHeaderBytes, head - wire::kFrameHeaderBytes),
          length)) {
    inPos_ = head;
    inEnd_ = head + after;
    placedAt_ = place + landed;
    placedLeft_ = expectedPlaced_ - landed;
    if (placedLeft_ == 0) completePlaced();
    return;
  }
  expectedHead_ = 0;
  std::unique_ptr<char[]> merged;
  char* to = in_.get();
  if (inCapacity_ < n) {
    merged.reset(new char[n]);
    std::memcpy(merged.get(), in_.get(), head);
    to = merged.get();
  }
  std::memmove(to + head + landed, in_.get() + head, after);
  std::memcpy(to + head, place, landed);
  if (merged) {
    in_ = std::move(merged);
    inCapacity_ = n;
  }
  inEnd_ = n;
}

// The last byte of the placed frame has arrived. The next read is small
// again (the head of the next big frame, with little of its data), unless
// the next frame is expected to be like this one.
void Link::completePlaced() {
  ++framesThisRead_;
  placedAt_ = nullptr;
  readRoom_ = kFirstReadRoom;
  handler_.onPlacedFrame(*this);
}

// The frames of a read to the handler. A frame placed by a read that
// filled its room is most likely all here already: its rest is read in the
// same turn (once: a flood of big frames still lets other work run).
void Link::afterRead(std::size_t n) {
  if (!closed_) parse();
  if (placedLeft_ > 0 && filled_ && !closed_) {
    if (const auto more = receive(); more > 0) {
      n += more;
      parse();
    }
  }
  noteReadShape(filled_);
  handler_.onReadDone(*this);
  shrinkIfIdle(n);
  read();
}

void Link::noteReadShape(bool filled) {
  drainedWhenShort_ = !filled && framesThisRead_ <= 1 && inPos_ == inEnd_ && placedLeft_ == 0 &&
                      skip_ == 0 && recordsPos_ == recordsEnd_;
  framesThisRead_ = 0;
}

void Link::shrinkIfIdle(std::size_t readBytes) {
  if (readBytes >= kFirstReadRoom) {
    smallReads_ = 0;
    return;
  }
  if (++smallReads_ < kIdleReads || inPos_ != inEnd_ || placedLeft_ > 0 || closed_) return;
  smallReads_ = 0;
  readRoom_ = kFirstReadRoom;
  expectedHead_ = 0;  // and the place reserved for it is let go
  placed_.reset();
  if (inCapacity_ > kFirstReadRoom) {
    in_.reset();
    inCapacity_ = 0;
  }
  // The write side is idle too only if little was written meanwhile (a
  // stream's writer reads little: only pings and answers).
  MutexLock lock(writeMu_);
  const bool writesIdle = writtenSinceIdle_ <= kFirstChunkBytes * kIdleReads;
  writtenSinceIdle_ = 0;
  if (!writesIdle) return;
  spareChunks_.clear();
  bigWrites_ = false;
  spareRecords_.clear();  // a secured stream's record blocks, kept while it ran
  idleWrites_ = true;     // a big chunk being written (a pong) is let go too
}

// Room after inEnd_ for `want` bytes (a read's, or an opened record's), or
// for the rest of a frame whose length is known to be bigger, so a big
// frame arrives in one piece (unless it will be placed: then only its head
// need arrive here). Returns the room made, which a read fills at most.
std::size_t Link::makeReadRoom(std::size_t want) {
  const std::size_t pending = inEnd_ - inPos_;
  if (pending >= wire::kFrameHeaderBytes) {
    const auto frame =
        wire::kFrameHeaderBytes + wire::frameLength(std::string_view(in_.get() + inPos_, 4));
    // (parse() has closed the link on an impossible length already)
    if (frame > pending && frame <= frameLimit() + wire::kFrameHeaderBytes &&
        !mayPlace(frame - wire::kFrameHeaderBytes)) {
      want = std::max(want, frame - pending);
    }
  }
  if (inCapacity_ - inEnd_ >= want) return want;
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
  return want;
}

// Room after recordsEnd_ for a read: the rest of the record under way, at
// least readRoom_, and the records of the rest of a frame whose length is
// known (its first records opened into in_), so a big frame's records
// arrive in one read, as an open link's frame does (makeReadRoom): a
// 64 KiB value took two reads and two wake-ups a hop. A record is at most
// kMaxPlainBytes + its overhead (before the handshake ends,
// kMaxHandshakeFrameBytes + it).
void Link::makeRecordRoom() {
  using security::RecordCipher;
  const auto pending = recordsEnd_ - recordsPos_;
  const auto whole = RecordCipher::recordLength(records_.get() + recordsPos_, pending);
  auto want = std::max(readRoom_, whole > pending ? whole - pending : 0);
  const std::size_t opened = inEnd_ - inPos_;
  if (opened >= wire::kFrameHeaderBytes) {
    const auto frame =
        wire::kFrameHeaderBytes + wire::frameLength(std::string_view(in_.get() + inPos_, 4));
    if (frame > opened && frame <= frameLimit() + wire::kFrameHeaderBytes) {
      // (its records may be cut otherwise: one record's overhead more)
      want =
          std::max(want, RecordCipher::sealedBytes(frame - opened) + RecordCipher::kOverheadBytes);
    }
  }
  if (recordsCapacity_ - recordsEnd_ >= want) return;
  if (recordsPos_ > 0) {
    std::memmove(records_.get(), records_.get() + recordsPos_, pending);
    recordsPos_ = 0;
    recordsEnd_ = pending;
  }
  if (recordsCapacity_ - recordsEnd_ < want) {
    std::unique_ptr<char[]> bigger(new char[recordsEnd_ + want]);
    if (recordsEnd_ > 0) std::memcpy(bigger.get(), records_.get(), recordsEnd_);
    records_ = std::move(bigger);
    recordsCapacity_ = recordsEnd_ + want;
  }
}

// Opens every whole record among those read, into in_ (out of place: one
// pass over the bytes).
bool Link::openRecords() {
  while (recordsPos_ < recordsEnd_) {
    const auto available = recordsEnd_ - recordsPos_;
    const auto whole =
        security::RecordCipher::recordLength(records_.get() + recordsPos_, available);
    if (whole != 0 && whole <= available && whole > security::RecordCipher::kOverheadBytes) {
      makeReadRoom(security::RecordCipher::plainLength(whole));
    }
    std::size_t record = 0, plain = 0;
    std::string error;
    const auto most =
        established_ ? security::RecordCipher::kMaxPlainBytes : wire::kMaxHandshakeFrameBytes;
    switch (cipher_->open(records_.get() + recordsPos_, available, most, in_.get() + inEnd_, record,
                          plain, error)) {
      case security::RecordCipher::Open::NeedMore:
        return true;
      case security::RecordCipher::Open::Bad:
        ++counters_.malformedFrames;
        ++counters_.garbagePeersDisconnected;
        close("bad record: " + error);
        return false;
      case security::RecordCipher::Open::Opened:
        inEnd_ += plain;
        recordsPos_ += record;
        break;
    }
  }
  recordsPos_ = recordsEnd_ = 0;
  if (recordsCapacity_ > (1u << 20)) {  // after a huge frame, as parse() lets in_ go
    records_.reset();
    recordsCapacity_ = 0;
  }
  return true;
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
    if (established_ && length > maxFrameBytes_ && length <= wire::kLargestFrameBytes) {
      // Over this PEIS's limit, not the protocol's: answer it from its head.
      const auto head = std::min<std::size_t>(length, wire::kOversizeHeadBytes);
      if (available < wire::kFrameHeaderBytes + head) break;
      const auto frame = std::string_view(in_.get() + inPos_ + wire::kFrameHeaderBytes, head);
      inPos_ += wire::kFrameHeaderBytes + head;
      skip_ = length - head;
      if (handler_.onOversize(*this, frame)) continue;
    }
    if (length == 0 || length > frameLimit()) {
      ++counters_.malformedFrames;
      ++counters_.garbagePeersDisconnected;
      return close("frame length " + std::to_string(length) +
                   (length == 0 ? " is impossible: garbage"
                                : " is over the " + std::to_string(frameLimit()) + " bytes taken" +
                                      (established_ ? "" : " before the handshake")));
    }
    if (available < wire::kFrameHeaderBytes + length) {
      // A big frame whose head has arrived: placed, if its handler names
      // the place (all the bytes read are the frame's).
      if (mayPlace(length) &&
          available >=
              wire::kFrameHeaderBytes + std::min<std::size_t>(length, wire::kOversizeHeadBytes)) {
        const auto head = std::string_view(in_.get() + inPos_ + wire::kFrameHeaderBytes,
                                           available - wire::kFrameHeaderBytes);
        std::size_t from = 0;
        if (char* place = handler_.placeFrame(*this, head, length, from)) {
          std::memcpy(place, head.data() + from, head.size() - from);
          placedAt_ = place + (head.size() - from);
          placedLeft_ = length - head.size();
          inPos_ = inEnd_;
          expectedHead_ = wire::kFrameHeaderBytes + from;
          expectedPlaced_ = length - from;
        } else {
          wholeFrame_ = true;
        }
      }
      break;
    }
    const auto frame = std::string_view(in_.get() + inPos_ + wire::kFrameHeaderBytes, length);
    inPos_ += wire::kFrameHeaderBytes + length;
    wholeFrame_ = false;
    ++framesThisRead_;
    handler_.onFrame(*this, frame);
    if (securing_) {  // what follows the peer's Hello is records
      securing_ = false;
      const auto rest = inEnd_ - inPos_;
      records_.reset(new char[std::max(rest, readRoom_)]);
      recordsCapacity_ = std::max(rest, readRoom_);
      if (rest > 0) std::memcpy(records_.get(), in_.get() + inPos_, rest);
      recordsPos_ = 0;
      recordsEnd_ = rest;
      inEnd_ = inPos_;
      if (!openRecords()) return;
    }
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
