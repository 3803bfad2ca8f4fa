// Outbox: the messages this PEIS has decided to send and the kernel thread
// has not handed to the network yet, one FIFO queue per destination
// (docs/architecture.md, "The outbox"; docs/protocol.md §13). Replication
// fills it (under the kernel lock, on whichever thread mutates); the kernel
// thread takes from it in bounded turns, skipping every destination whose
// link is congested. Backpressure is therefore per destination: what waits
// for a slow peer stays in that peer's queue, where tuple updates coalesce
// (a newer value of a tuple replaces the one still waiting, never across
// another message), while every other destination is served as usual.
//
// Tuple updates are normally encoded at once into runs of whole frames (the
// kernel thread then only hands bytes to a link); a big tuple, and every
// update while its destination's queue is backed up, waits as the tuple
// itself. Not thread-safe: the Kernel serialises access.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "net/wire.h"
#include "tuple_space.h"

namespace peis {

class Outbox {
 public:
  // One entry for one destination: a run of tuple updates already encoded
  // as whole frames, one update kept as a tuple, or another routed body.
  struct Outgoing {
    Outgoing() = default;
    Outgoing(PeisId to, TuplePtr tuple) : destination(to), update(std::move(tuple)) {}
    Outgoing(PeisId to, std::nullptr_t, wire::RoutedBody message)
        : destination(to), body(std::make_unique<wire::RoutedBody>(std::move(message))) {}
    PeisId destination = 0;
    TuplePtr update;
    std::unique_ptr<wire::RoutedBody> body;
    std::string frames;  // whole TupleUpdate frames, length prefixes included
    std::uint32_t frameCount = 0;
  };

  // Bytes of tuple updates waiting for one destination above which an update
  // is queued as a tuple (its position remembered), and above which a newer
  // value replaces a remembered one still waiting.
  static constexpr std::size_t kTrackAbove = 2u << 20;
  static constexpr std::size_t kCoalesceAbove = 4u << 20;
  // Encoded frames per entry, at most (about; one frame may exceed it).
  static constexpr std::size_t kFramesPerEntryBytes = 64u << 10;

  Outbox(PeisId self, std::uint64_t incarnation) : self_(self), incarnation_(incarnation) {}

  // Queues a message other than a tuple update. Nothing coalesces across it.
  void push(Outgoing outgoing);
  // Queues an update of an own tuple for `destination`.
  void pushUpdate(PeisId destination, const TuplePtr& tuple);

  // Takes up to `most` entries, destination by destination in the order
  // they started waiting, skipping those `blocked` names, and stops early
  // once the entries taken carry `mostBytes` of updates (at least one entry
  // is taken if any can be). Returns whether entries that could be taken
  // are left. `noteBlocked` false: the destinations skipped are not
  // remembered as blocked (a direct send's take, whose reasons to skip are
  // its own).
  bool take(std::vector<Outgoing>& out, std::size_t most = SIZE_MAX,
            std::size_t mostBytes = SIZE_MAX, const std::function<bool(PeisId)>& blocked = {},
            bool noteBlocked = true);
  // Whether anything waits that the last take() did not find blocked.
  bool hasReady() const;
  bool empty() const { return order_.empty(); }
  // Every destination counts as unblocked again (a link drained).
  void unblockAll();

  // Bytes of tuple updates waiting, for all destinations / for one.
  std::size_t bytes() const { return bytes_; }
  std::size_t bytesFor(PeisId destination) const;
  // Everything waiting for `destination`, messages included (estimated).
  std::size_t waitingFor(PeisId destination) const;
  // The destinations the last take() found blocked.
  std::vector<PeisId> blocked() const;
  // Forgets what waits for a destination (it is gone, or cut off).
  void drop(PeisId destination);
  // This PEIS took a new id: frames encoded with the old one are dropped.
  void changeSelf(PeisId self);
  // Gives back the memory of an entry's frames once they were handed on.
  // Up to kSpareEntries are kept: as many as a writer that outruns its
  // subscriber has waiting (kWriterWaitAbove, 1 MiB, is 16 entries); with
  // fewer, the entries beyond them were fresh memory, about 30 page faults
  // per 1,000 updates of a 16-byte stream.
  void recycleFrames(std::string&& frames);
  // Lets the spare entries beyond kSpareEntriesIdle go (now and then: a
  // PEIS that streamed once does not keep 1 MiB).
  void trimSpares();
  static constexpr std::size_t kSpareEntries = 17;
  static constexpr std::size_t kSpareEntriesIdle = 4;
  // Updates replaced by a newer value of the same tuple.
  std::uint64_t coalesced() const { return coalesced_; }

 private:
  struct Queue {
    std::deque<Outgoing> entries;
    std::uint64_t base = 0;  // absolute index of entries.front()
    // Per key, the absolute index of a waiting update a newer one may replace.
    std::map<std::string, std::uint64_t> pending;
    std::size_t bytes = 0;     // of updates (frames and tuples)
    std::size_t messages = 0;  // estimated bytes of the other messages
    bool blocked = false;      // its link was congested at the last take()
    bool listed = false;       // in order_ (it has entries)
    // Encodes the destination's updates (a stream's repeated fields once).
    wire::TupleUpdateEncoder encoder;
  };
  Queue& queueFor(PeisId destination);
  void appendFrame(PeisId destination, Queue& queue, const Tuple& tuple);
  void erase(std::map<PeisId, Queue>::iterator queue);
  static std::size_t updateBytes(const Outgoing& entry);

  PeisId self_;
  std::uint64_t incarnation_;
  std::map<PeisId, Queue> queues_;
  std::deque<PeisId> order_;  // destinations with entries, in the order they started waiting
  std::size_t bytes_ = 0;
  std::vector<std::string> spareFrames_;
  std::uint64_t coalesced_ = 0;
  // The queue used last (a stream goes to one destination).
  PeisId lastDestination_ = 0;
  Queue* lastQueue_ = nullptr;
};

}  // namespace peis
