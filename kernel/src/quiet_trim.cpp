// Handing freed heap memory back after a quiet period; see quiet_trim.h.
#include "quiet_trim.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace peis {

void QuietTrim::noteChange() {
  changedAt_ = std::chrono::steady_clock::now();
  if (!armed_) arm(changedAt_ + quietFor_);
}

void QuietTrim::arm(std::chrono::steady_clock::time_point at) {
  armed_ = true;
  framesAtArm_ = frames_();
  timer_.expires_at(at);
  timer_.async_wait([this](const boost::system::error_code& ec) {
    armed_ = false;
    if (ec) return;
    const auto quietFrom = changedAt_ + quietFor_;
    const auto now = std::chrono::steady_clock::now();
    if (now < quietFrom) return arm(quietFrom);
    if (frames_() - framesAtArm_ > kBusyFrames) return arm(now + quietFor_);  // data moves
#if defined(__GLIBC__)
    // madvise(MADV_DONTNEED)s the free pages of every arena, not only the
    // top of each heap; a few tens of microseconds for a PEIS's heap.
    malloc_trim(0);
#endif
    ++trims_;
  });
}

}  // namespace peis
