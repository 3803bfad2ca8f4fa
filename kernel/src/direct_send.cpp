// DirectSend: a batch of outbox entries sent by the thread that queued them;
// see direct_send.h.
#include "direct_send.h"

#include <algorithm>

namespace peis {

namespace {
// The frames' memory of this thread's last direct send (an application
// thread that writes keeps reusing one buffer through the outbox).
thread_local std::string lastFrames;
}  // namespace

std::string DirectSend::spareFrames() { return std::exchange(lastFrames, std::string()); }

// The links' write locks are held from admit() to send(): the analysis
// cannot follow locks held in a container.
bool DirectSend::admit(const std::shared_ptr<net::Link>& link,
                       std::size_t mostBacklog) NO_THREAD_SAFETY_ANALYSIS {
  if (std::find(links_.begin(), links_.end(), link) != links_.end()) return true;
  if (!link->lockForDirect(mostBacklog)) return false;
  links_.push_back(link);
  return true;
}

void DirectSend::add(net::Link* link, Outbox::Outgoing&& entry) {
  items_.push_back(Item{link, std::move(entry)});
}

void DirectSend::send() NO_THREAD_SAFETY_ANALYSIS {
  if (links_.empty()) return;
  std::string frame;
  for (auto& [link, out] : items_) {
    const wire::Envelope envelope{self_, out.destination, wire::kDefaultTtl};
    if (out.frameCount > 0) {
      link->sendNow(out.frames, nullptr, out.frameCount);
      if (out.frames.capacity() > lastFrames.capacity() &&
          out.frames.capacity() <= 2 * Outbox::kFramesPerEntryBytes) {
        lastFrames = std::move(out.frames);
      }
    } else if (out.update) {
      const bool big = out.update->data.size() >= wire::kZeroCopyDataBytes;
      frame.clear();
      wire::encodeTupleUpdate(envelope, incarnation_, *out.update, frame,
                              big ? wire::TupleData::Omit : wire::TupleData::Include);
      link->sendNow(frame, big ? out.update : nullptr, 1);
    } else {
      link->sendNow(wire::encodeFrame(wire::RoutedMessage{envelope, std::move(*out.body)}), nullptr,
                    1);
    }
  }
  for (auto& link : links_) link->unlockWrites();
  items_.clear();
  links_.clear();
}

}  // namespace peis
