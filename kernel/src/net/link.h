// Link: one TCP connection to another PEIS, as bytes and frames. It reads
// straight into its frame buffer and hands each whole frame to its handler
// (the Network), and writes queued frames in chunks with gathered writes (the
// data of a big tuple is written from the stored tuple itself). It knows
// nothing of routing or of what frames mean, beyond their length prefix; the
// handshake state and the peer's Hello are kept here for the Network.
// Kernel thread only (the io_context's), except sendNow() and
// takesDirect(), which any thread may call: the write side (the queue, the
// write under way, the socket's closing) is guarded by the link's own
// write lock for them (docs/architecture.md, "Direct sends").
#pragma once

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <chrono>
#include <cstddef>
#include <deque>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "adaptive_mutex.h"
#include "net/link_socket.h"
#include "net/wire.h"

namespace peis::security {
class RecordCipher;
}

namespace peis::net {

struct Counters;
struct LinkSecurity;
class Link;

// What a Link reports to its owner.
class LinkHandler {
 public:
  // One whole frame (type and body, without the length prefix); it lives
  // only for the call.
  virtual void onFrame(Link& link, std::string_view frame) = 0;
  // The head (the first kOversizeHeadBytes) of a frame longer than this
  // PEIS's limit but within the protocol's: the rest is skipped. True when
  // answered (docs/protocol.md §2.1); false makes it a framing error.
  virtual bool onOversize(Link& link, std::string_view head) = 0;
  // A big frame has begun (placed frames, below): `head` is what has
  // arrived of it (type first; every field before a tuple's data at
  // least), `length` its whole length. The handler takes what it needs of
  // `head` and returns where the frame's bytes from `from` (at most
  // head.size()) on go, or null to have the frame read whole into the
  // link's buffer and given to onFrame as any other.
  virtual char* placeFrame(Link& link, std::string_view head, std::size_t length,
                           std::size_t& from) = 0;
  // Where the last `bytes` of the next frame go if it is like the frame
  // placed last (the same length, its place at the same offset): the next
  // read puts them there before the frame's head is seen. Null: nowhere.
  virtual char* reservePlace(Link& link, std::size_t bytes) = 0;
  // A read put a frame's last bytes into the reserved place: true if the
  // frame (its `head`, every byte before the place, and its `length`) is
  // one whose bytes belong there; false takes them back to be read whole.
  virtual bool placeReserved(Link& link, std::string_view head, std::size_t length) = 0;
  // The last byte of the frame placeFrame() or placeReserved() took has
  // arrived.
  virtual void onPlacedFrame(Link& link) = 0;
  // Every frame of one socket read was handed over.
  virtual void onReadDone(Link& link) = 0;
  // A write finished (the link's backlog() went down).
  virtual void onWritten(Link& link) = 0;
  // The link closed (by either end, or an error); it sends and reads no more.
  virtual void onClosed(Link& link, const std::string& reason) = 0;

 protected:
  ~LinkHandler() = default;
};

// Placed frames: on an open, established link, a frame of kPlacedFrameBytes
// or more (a big tuple update) is not read whole into the link's buffer and
// copied out of it by the decoder: once its head has arrived, the handler
// decodes the head and names the frame's final place (the tuple's data),
// and the rest of the frame is read straight there, together with what
// follows it into the buffer (one scattered read). The read after a placed
// frame is small (kFirstReadRoom), so the head of the next big frame comes
// with little of its data; and when that read begins a frame, it expects
// one like the last placed (a round trip's or a stream's next value): its
// head into the buffer, the rest into a place the handler reserves, in one
// read. A frame that is not like it is put back together in the buffer (a
// copy) and nothing is expected until a frame is placed again.
class Link : public std::enable_shared_from_this<Link> {
 public:
  static constexpr std::size_t kPlacedFrameBytes = 32 * 1024;

  using SteadyClock = std::chrono::steady_clock;

  // `maxFrameBytes`: the largest frame length accepted once the handshake
  // is complete (a bigger one is a framing error: the link closes); until
  // then it is wire::kMaxHandshakeFrameBytes. `explicitIndex`: the
  // --peis-connect entry it serves, or -1.
  Link(LinkHandler& handler, Counters& counters, std::size_t maxFrameBytes,
       boost::asio::ip::tcp::socket socket, bool outbound, int explicitIndex);
  ~Link();

  // Sends our Hello and starts reading.
  void start(const wire::Hello& hello);
  // Queues one whole encoded frame (length prefix included).
  void sendFrame(std::string_view frame);
  // Queues a tuple update encoded straight from the stored tuple (a big
  // tuple's data is written from the tuple, which the queue keeps alive).
  void sendUpdate(const wire::Envelope& envelope, std::uint64_t incarnation,
                  const std::shared_ptr<const Tuple>& tuple);
  // Queues `frames` whole frames encoded elsewhere (copied).
  void sendBytes(std::string_view bytes, std::uint32_t frames);
  void close(const std::string& reason);
  // The handshake is complete: frames up to maxFrameBytes are taken now.
  void establish() { established_ = true; }
  // Secured links (docs/protocol.md §15.5): from now on, everything written
  // goes out as `cipher`'s records, and everything read after the frame
  // being handled (the peer's Hello) is taken as its records. Only from
  // the LinkHandler's onFrame.
  void secure(std::unique_ptr<security::RecordCipher> cipher);
  bool secured() const { return cipher_ != nullptr; }
  // Our Hello's bytes after the length field (a secured handshake signs them).
  const std::string& ownHello() const { return ownHello_; }
  // Sends what is queued, then closes.
  void closeAfterFlush(const std::string& reason);

  // --- Direct sends, from any thread ------------------------------------------
  // Takes the write lock if the link takes a direct send: it is open, not
  // found congested, and holds at most `mostBacklog` bytes; else leaves it
  // and returns false. What is sent to the link after the lock was taken
  // (by anybody) queues behind what the holder sends.
  bool lockForDirect(std::size_t mostBacklog) TRY_ACQUIRE(true, writeMu_);
  void unlockWrites() RELEASE(writeMu_) { writeMu_.unlock(); }
  // Sends `frames` whole frames (`bytes`, then `tail`'s data when set, which
  // ends the last frame) from the calling thread: written to the socket at
  // once when nothing else is queued or being written (the rest, if the
  // socket takes only part, is written by the kernel thread), else queued
  // behind what is. Dropped when the link has closed. Returns the bytes
  // written at once (a secured link: all of them, or 0 when the socket took
  // only part of the records).
  // On a secured link the frames are sealed into records first, here,
  // under the write lock (as the kernel thread's writes are).
  std::size_t sendNow(std::string_view bytes, const std::shared_ptr<const Tuple>& tail,
                      std::uint32_t frames) REQUIRES(writeMu_);

  // Bytes queued or being written.
  std::size_t backlog() const {
    MutexLock lock(writeMu_);
    return inFlight_ + queued_;
  }
  // Bytes have arrived that are not read yet (a sign of life).
  bool bytesWaiting();
  // The peer's TCP stack has acknowledged everything this end sent (its
  // host lives and takes our bytes, though its process may be slow).
  bool peerAcknowledgesAll();
  // Part of a frame has arrived and the rest has not (a big frame in transit).
  bool midFrame() const {
    return inEnd_ > inPos_ || skip_ > 0 || placedLeft_ > 0 || recordsEnd_ > recordsPos_;
  }
  bool closed() const { return closed_; }
  // The memory of the read buffer and of the spare write chunk (an idle
  // link's is small: shrinkIfIdle).
  std::size_t bufferBytes() const {
    MutexLock lock(writeMu_);
    std::size_t spare = 0;
    for (const auto& chunk : spareChunks_) spare += chunk.capacity();
    return inCapacity_ + spare + spareRecords_.size() * kRecordBlockBytes;
  }
  // How long the write under way has been waiting for the peer to take it
  // (zero when none is).
  SteadyClock::duration writeWaiting(SteadyClock::time_point now) const {
    MutexLock lock(writeMu_);
    return writing_ ? now - writingSince_ : SteadyClock::duration::zero();
  }
  // The last write started (by this thread or a direct send).
  SteadyClock::time_point lastSent() const {
    MutexLock lock(writeMu_);
    return lastSent_;
  }

  // --- State the Network keeps about the link --------------------------------
  const bool outbound_;
  const int explicitIndex_;
  std::string remote_;                // address:port
  std::string remoteAddress_;         // the address alone (connection caps count per address)
  SteadyClock::time_point openedAt_;  // the handshake deadline counts from here
  bool established_ = false;
  wire::Hello peer_;  // the peer's Hello, once established_
  SteadyClock::time_point lastHeard_;
  SteadyClock::time_point establishedAt_;
  int malformed_ = 0;
  // The last source whose frames passed the Network's source checks on this
  // link, and the routes epoch they were checked in.
  PeisId checkedSource_ = 0;
  std::uint64_t checkedEpoch_ = 0;
  PeisId dialTarget_ = 0;  // the beacon peer this link was dialled for
  // Found congested by the Network (its backlog over the high-water mark);
  // cleared when it drains to half. Read by lockForDirect() on any thread.
  std::atomic<bool> congested_{false};
  // The message of the frame being placed (its data read into place); made
  // at the link's first placed frame.
  std::unique_ptr<wire::RoutedMessage> placed_;
  // What the Network keeps of a secured link (net/link_security.h); null in
  // an open ecology.
  std::unique_ptr<LinkSecurity> security_;

 private:
  // A secured link's records sealed as they are queued wait in blocks of
  // this size (a few whole records each). The blocks of one gathered write
  // (1 MiB) are kept for the next when written: a stream then allocates and
  // faults in none (the records' buffer of a write used to keep as much).
  static constexpr std::size_t kRecordBlockBytes = 64 * 1024;
  static constexpr std::size_t kSpareRecordBlocks = 16;
  // Frames waiting to be written: bytes, then (when set) a tuple's data,
  // which is the end of the frame those bytes begin.
  struct Chunk {
    std::string bytes;
    std::shared_ptr<const Tuple> tail;
    // A secured link's records, sealed as they were queued: its first
    // recordBytes of recordRoom, written as they are (null: `bytes` and
    // `tail` are frames, sealed when written).
    std::unique_ptr<char[]> records;
    std::size_t recordBytes = 0, recordRoom = 0;
    std::size_t size() const { return bytes.size() + recordBytes + (tail ? tail->data.size() : 0); }
  };
  std::string& appendable(std::size_t bytes) REQUIRES(writeMu_);
  void keepSpareChunk() REQUIRES(writeMu_);
  void write() REQUIRES(writeMu_);
  void startWrite() REQUIRES(writeMu_);
  // A secured link's frames, sealed at once: written, or queued as records.
  void sendSealed(std::string_view bytes, const std::shared_ptr<const Tuple>& tail)
      REQUIRES(writeMu_);
  void writeSealed(std::string_view bytes, std::string_view data) REQUIRES(writeMu_);
  void queueSealed(std::string_view bytes, const std::shared_ptr<const Tuple>& tail)
      REQUIRES(writeMu_);
  void sealQueued(std::string_view plain) REQUIRES(writeMu_);
  Chunk& newRecordBlock(std::size_t bytes) REQUIRES(writeMu_);
  void sealChunks() REQUIRES(writeMu_);
  void sealRoom(std::size_t bytes) REQUIRES(writeMu_);
  // sendNow on an idle secured link: seals and writes at once.
  std::size_t sendSealedNow(std::string_view bytes, std::string_view data) REQUIRES(writeMu_);
  // Starts the write that a direct send left to this thread.
  void resumeWrite() EXCLUDES(writeMu_);
  void read();
  // Back to small buffers once reads have been small for a while.
  void shrinkIfIdle(std::size_t readBytes);
  std::size_t makeReadRoom(std::size_t want);
  std::size_t receive();
  void received(std::size_t n, std::size_t asked);
  void receivedAsExpected(std::size_t n);
  void completePlaced();
  void afterRead(std::size_t n);
  void noteReadShape(bool filled);
  // Whether the frame at inPos_ (of `length` bytes) may be placed.
  bool mayPlace(std::size_t length) const {
    return established_ && !cipher_ && !wholeFrame_ && length >= kPlacedFrameBytes;
  }
  void makeRecordRoom();
  void parse();
  // Opens the whole records among the bytes read; false if the link closed.
  bool openRecords();
  std::size_t frameLimit() const {
    return established_ ? maxFrameBytes_ : wire::kMaxHandshakeFrameBytes;
  }

  LinkHandler& handler_;
  Counters& counters_;
  const std::size_t maxFrameBytes_;
  LinkSocket socket_;
  bool closed_ = false;
  std::unique_ptr<char[]> in_;
  std::size_t inCapacity_ = 0;
  std::size_t readRoom_;
  std::size_t inPos_ = 0, inEnd_ = 0;
  // A secured link: the records read and not opened yet, [recordsPos_,
  // recordsEnd_) of records_; their plaintext goes to in_. cipher_ is set
  // by the kernel thread under writeMu_ (secure()), so a direct sender
  // reads it under writeMu_; its sealing side is used under writeMu_ only,
  // its opening side by the kernel thread only (RecordCipher keeps the two
  // apart).
  std::unique_ptr<security::RecordCipher> cipher_;
  std::unique_ptr<char[]> records_;
  std::size_t recordsCapacity_ = 0, recordsPos_ = 0, recordsEnd_ = 0;
  bool securing_ = false;  // secure() was called from the frame being handled
  std::string ownHello_;
  std::size_t skip_ = 0;  // bytes of an oversized frame still to be skipped
  // A placed frame: where its next bytes go, and how many are still to come.
  char* placedAt_ = nullptr;
  std::size_t placedLeft_ = 0;
  bool wholeFrame_ = false;  // the handler declined the frame at inPos_: read it whole
  // The frame expected next (like the last placed): the bytes before its
  // place, and in it (expectedHead_ 0: none expected); the place reserved
  // for it by the read under way.
  std::size_t expectedHead_ = 0, expectedPlaced_ = 0;
  char* reserved_ = nullptr;
  bool filled_ = false;     // the last read filled all the room it had
  std::size_t asked_ = 0;   // the room of the read under way
  int smallReads_ = 0;      // reads in a row smaller than the first read room
  int framesThisRead_ = 0;  // frames handed over from the read under way
  // The last read held at most one frame, whole, and did not fill its room
  // (a request, an answer, a value now and then; not a stream): a read as
  // short as it leaves the socket empty, and the read after it waits for
  // epoll without trying the socket first (net/link_socket.h).
  bool drainedWhenShort_ = false;
  // --- The write side: the kernel thread and direct senders -----------------------
  mutable AdaptiveMutex writeMu_;
  bool writeClosed_ GUARDED_BY(writeMu_) = false;      // the socket is closed (or closing)
  std::vector<Chunk> outChunks_ GUARDED_BY(writeMu_);  // being written
  std::vector<std::string> spareChunks_
      GUARDED_BY(writeMu_);  // written chunks' memory, for the next
  std::vector<std::unique_ptr<char[]>> spareRecords_ GUARDED_BY(writeMu_);  // written record blocks
  // The link is idle (shrinkIfIdle): a written chunk bigger than the first
  // size is freed, not kept, until a chunk grows again.
  bool idleWrites_ GUARDED_BY(writeMu_) = false;
  // A chunk has grown past the first size since the link was last idle (a
  // stream): new chunks take their full size at once.
  bool bigWrites_ GUARDED_BY(writeMu_) = false;
  std::size_t writtenSinceIdle_ GUARDED_BY(writeMu_) = 0;  // by write(), since the last check
  std::vector<boost::asio::const_buffer> outBuffers_ GUARDED_BY(writeMu_);
  std::size_t inFlight_ GUARDED_BY(writeMu_) = 0;
  std::deque<Chunk> chunks_ GUARDED_BY(writeMu_);
  std::size_t queued_ GUARDED_BY(writeMu_) = 0;
  // A write is under way, or a direct send left one to the kernel thread.
  bool writing_ GUARDED_BY(writeMu_) = false;
  SteadyClock::time_point writingSince_ GUARDED_BY(writeMu_);
  SteadyClock::time_point lastSent_ GUARDED_BY(writeMu_);  // the last write started
  std::string closeReason_ GUARDED_BY(writeMu_);
  // A secured link: the records being written, sealed_'s first
  // sealedBytes_ (its size is only the room it has).
  std::string sealed_ GUARDED_BY(writeMu_);
  std::size_t sealedBytes_ GUARDED_BY(writeMu_) = 0;
  std::string plain_ GUARDED_BY(writeMu_);  // a tuple update encoded to be sealed (writeSealed)
};

}  // namespace peis::net
