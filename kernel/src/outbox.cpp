// Outbox: per-destination queues of outgoing messages, with coalescing; see
// outbox.h.
#include "outbox.h"

#include <algorithm>

#include "net/string_room.h"

namespace peis {

namespace {

// What a message other than an update is counted as while it waits.
constexpr std::size_t kMessageBytes = 64;

}  // namespace

Outbox::Queue& Outbox::queueFor(PeisId destination) {
  Queue* queue = lastQueue_;
  if (!queue || lastDestination_ != destination) {
    queue = &queues_[destination];  // kept while the destination lives (its memory reused)
    lastDestination_ = destination;
    lastQueue_ = queue;
  }
  if (!queue->listed) {
    queue->listed = true;
    order_.push_back(destination);
  }
  return *queue;
}

void Outbox::erase(std::map<PeisId, Queue>::iterator queue) {
  if (lastQueue_ == &queue->second) lastQueue_ = nullptr;
  bytes_ -= std::min(bytes_, queue->second.bytes);
  if (queue->second.listed) order_.erase(std::find(order_.begin(), order_.end(), queue->first));
  queues_.erase(queue);
}

std::size_t Outbox::updateBytes(const Outgoing& entry) {
  return entry.frames.size() + (entry.update ? wire::tupleUpdateFrameBytes(*entry.update) : 0);
}

void Outbox::push(Outgoing outgoing) {
  auto& queue = queueFor(outgoing.destination);
  queue.pending.clear();  // nothing coalesces across another message
  queue.messages += kMessageBytes;
  queue.entries.push_back(std::move(outgoing));
}

void Outbox::pushUpdate(PeisId destination, const TuplePtr& tuple) {
  auto& queue = queueFor(destination);
  const bool big = tuple->data.size() >= wire::kZeroCopyDataBytes;
  if (queue.bytes < kTrackAbove && !big) return appendFrame(destination, queue, *tuple);
  const auto bytes = wire::tupleUpdateFrameBytes(*tuple);
  if (queue.bytes < kTrackAbove) {
    // A big tuple is not copied into a frame: the link writes its data from
    // the tuple itself.
    queue.pending.clear();
    queue.entries.emplace_back(destination, tuple);
    queue.bytes += bytes;
    bytes_ += bytes;
    return;
  }
  // Backed up (its link is congested): queue the tuple itself, so that a
  // newer value can still take its place.
  auto it = queue.pending.find(tuple->key);
  if (queue.bytes >= kCoalesceAbove && it != queue.pending.end() && it->second >= queue.base) {
    // Overload: the owner writes faster than this peer reads. Keep the
    // newest value in the place of the one still waiting (latest value).
    auto& waiting = queue.entries[it->second - queue.base];
    const auto old = wire::tupleUpdateFrameBytes(*waiting.update);
    queue.bytes = queue.bytes + bytes - old;
    bytes_ = bytes_ + bytes - old;
    waiting.update = tuple;
    ++coalesced_;
    return;
  }
  queue.pending.insert_or_assign(tuple->key, queue.base + queue.entries.size());
  queue.entries.emplace_back(destination, tuple);
  queue.bytes += bytes;
  bytes_ += bytes;
}

void Outbox::appendFrame(PeisId destination, Queue& queue, const Tuple& tuple) {
  // An entry is cut before a frame would take it over kFramesPerEntryBytes:
  // its memory then never grows past that (a string of twice that size is
  // an mmap of its own, and a stream's entries paid fresh pages for it).
  const auto bytes = wire::tupleUpdateFrameBytes(tuple);
  const bool extend = !queue.entries.empty() && queue.entries.back().frameCount > 0 &&
                      queue.entries.back().frames.size() + bytes <= kFramesPerEntryBytes;
  if (!extend) {
    queue.pending.clear();  // no waiting update may be replaced across these frames
    auto& entry = queue.entries.emplace_back();
    entry.destination = destination;
    if (!spareFrames_.empty()) {
      entry.frames = std::move(spareFrames_.back());
      spareFrames_.pop_back();
    } else {
      entry.frames.reserve(4096);
    }
  }
  auto& entry = queue.entries.back();
  const auto before = entry.frames.size();
  // An entry that outgrows its first buffer is a stream's: it grows once,
  // to all it may hold, rather than by doubling (a copy of its frames each
  // time).
  if (entry.frames.capacity() < before + bytes) {
    entry.frames.reserve(std::max(before + bytes, kFramesPerEntryBytes));
  }
  // Sized without zero-filling: the encoder writes every byte.
  net::resizeForOverwrite(entry.frames, before + bytes);
  queue.encoder.write(wire::Envelope{self_, destination, wire::kDefaultTtl}, incarnation_, tuple,
                      entry.frames.data() + before);
  ++entry.frameCount;
  queue.bytes += bytes;
  bytes_ += bytes;
}

bool Outbox::take(std::vector<Outgoing>& out, std::size_t most, std::size_t mostBytes,
                  const std::function<bool(PeisId)>& blocked, bool noteBlocked) {
  std::size_t count = 0, bytes = 0;
  bool more = false;
  for (std::size_t i = 0; i < order_.size();) {
    const auto destination = order_[i];
    auto it = queues_.find(destination);
    auto& queue = it->second;
    const bool skip = blocked && blocked(destination);
    if (noteBlocked) queue.blocked = skip;
    if (skip) {
      ++i;
      continue;
    }
    if (count >= most || (count > 0 && bytes >= mostBytes)) {
      more = true;
      break;
    }
    while (!queue.entries.empty() && count < most && (count == 0 || bytes < mostBytes)) {
      auto& front = queue.entries.front();
      const auto entryBytes = updateBytes(front);
      if (!front.frameCount && !front.update) {
        queue.messages -= std::min(queue.messages, kMessageBytes);
      }
      bytes += entryBytes;
      queue.bytes -= std::min(queue.bytes, entryBytes);
      bytes_ -= std::min(bytes_, entryBytes);
      out.push_back(std::move(front));
      queue.entries.pop_front();
      ++queue.base;
      ++count;
    }
    if (!queue.entries.empty()) {
      more = true;
      break;
    }
    // Drained: it leaves the order (and comes back at its end).
    queue.listed = false;
    queue.pending.clear();
    queue.messages = 0;
    order_.erase(order_.begin() + static_cast<std::ptrdiff_t>(i));
  }
  return more;
}

bool Outbox::hasReady() const {
  for (const auto destination : order_) {
    if (!queues_.at(destination).blocked) return true;
  }
  return false;
}

void Outbox::unblockAll() {
  for (auto& [destination, queue] : queues_) queue.blocked = false;
}

std::size_t Outbox::bytesFor(PeisId destination) const {
  const auto it = queues_.find(destination);
  return it == queues_.end() ? 0 : it->second.bytes;
}

std::size_t Outbox::waitingFor(PeisId destination) const {
  const auto it = queues_.find(destination);
  return it == queues_.end() ? 0 : it->second.bytes + it->second.messages;
}

std::vector<PeisId> Outbox::blocked() const {
  std::vector<PeisId> ids;
  for (const auto destination : order_) {
    if (queues_.at(destination).blocked) ids.push_back(destination);
  }
  return ids;
}

void Outbox::drop(PeisId destination) {
  const auto it = queues_.find(destination);
  if (it != queues_.end()) erase(it);
}

void Outbox::changeSelf(PeisId self) {
  self_ = self;
  for (auto it = queues_.begin(); it != queues_.end();) {
    auto& queue = it->second;
    std::deque<Outgoing> keep;
    for (auto& out : queue.entries) {
      if (out.frameCount == 0) keep.push_back(std::move(out));
    }
    queue.entries = std::move(keep);
    queue.pending.clear();
    bytes_ -= std::min(bytes_, queue.bytes);
    queue.bytes = 0;
    for (const auto& out : queue.entries) queue.bytes += updateBytes(out);
    bytes_ += queue.bytes;
    if (queue.entries.empty() && queue.listed) {
      queue.listed = false;
      order_.erase(std::find(order_.begin(), order_.end(), it->first));
    }
    ++it;
  }
}

void Outbox::recycleFrames(std::string&& frames) {
  if (spareFrames_.size() >= kSpareEntries || frames.capacity() > 2 * kFramesPerEntryBytes) return;
  frames.clear();
  spareFrames_.push_back(std::move(frames));
}

void Outbox::trimSpares() {
  if (spareFrames_.size() > kSpareEntriesIdle) spareFrames_.resize(kSpareEntriesIdle);
}

}  // namespace peis
