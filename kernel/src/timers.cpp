// TimerTable: application timers on the kernel thread; see timers.h.
#include "timers.h"

#include <boost/asio/post.hpp>
#include <string>

#include "saturating_time.h"

namespace peis {

TimerTable::TimerTable(boost::asio::io_context& io, std::function<void(std::string_view)> threw)
    : io_(io), threw_(std::move(threw)) {}

TimerTable::Handle TimerTable::add(std::chrono::milliseconds delay,
                                   std::chrono::milliseconds period, std::function<void()> fn) {
  auto timer = std::make_shared<Timer>();
  timer->timer = std::make_shared<boost::asio::steady_timer>(io_);
  timer->fn = std::move(fn);
  timer->period = period;
  Handle handle;
  {
    MutexLock lock(mu_);
    handle = next_++;
    timer->handle = handle;
    timers_.emplace(handle, timer);
  }
  boost::asio::post(io_, [this, timer, delay] { start(timer, delay); });
  return handle;
}

void TimerTable::start(const std::shared_ptr<Timer>& timer, std::chrono::milliseconds delay) {
  timer->timer->expires_after(saturatingCast<std::chrono::steady_clock::duration>(delay));
  timer->timer->async_wait([this, timer](const boost::system::error_code& ec) {
    if (ec || !timer->active) return;
    if (timer->period.count() == 0) {
      // A one-shot timer leaves the table as it fires (it would stay there
      // forever otherwise); if cancel() took it first, it does not run.
      MutexLock lock(mu_);
      if (timers_.erase(timer->handle) == 0) return;
    }
    try {
      timer->fn();
    } catch (const std::exception& e) {
      threw_(std::string("a timer callback threw: ") + e.what());
    } catch (...) {  // anything else would end the kernel thread (std::terminate)
      threw_("a timer callback threw");
    }
    if (timer->period.count() > 0 && timer->active) start(timer, timer->period);
  });
}

bool TimerTable::cancel(Handle handle) {
  std::shared_ptr<Timer> timer;
  {
    MutexLock lock(mu_);
    auto it = timers_.find(handle);
    if (it == timers_.end()) return false;
    timer = it->second;
    timers_.erase(it);
  }
  timer->active = false;
  boost::asio::post(io_, [timer] { timer->timer->cancel(); });
  return true;
}

void TimerTable::stopAll() {
  MutexLock lock(mu_);
  for (auto& [handle, timer] : timers_) timer->active = false;
}

}  // namespace peis
