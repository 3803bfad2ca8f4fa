// RemoteWrites: pending writes to other owners; see remote_writes.h.
#include "remote_writes.h"

#include <algorithm>
#include <random>
#include <vector>

namespace peis {

RemoteWrites::RemoteWrites(boost::asio::io_context& io,
                           std::function<void(std::string_view)> completionThrew)
    : io_(io), completionThrew_(std::move(completionThrew)) {
  std::random_device seed;
  nextRequest_ = ((std::uint64_t{seed()} << 32) ^ seed()) >> 1 | 1;  // room to count up
}

std::uint64_t RemoteWrites::add(PeisId owner, WriteDone done, std::chrono::milliseconds timeout,
                                std::function<void(std::uint64_t)> resend) {
  const auto request = nextRequest_++;
  auto timer = std::make_shared<boost::asio::steady_timer>(io_, timeout);
  pending_[request] = Pending{std::move(done), timer, owner, nullptr};
  timer->async_wait([this, request, owner, timeout](const boost::system::error_code& ec) {
    if (ec) return;
    complete(request,
             Error(ErrorCode::Timeout, "PEIS " + std::to_string(owner) + " did not answer within " +
                                           std::to_string(timeout.count()) + " ms"),
             0);
  });
  if (resend) {
    scheduleRetry(request, kFirstRetry, std::chrono::steady_clock::now() + timeout,
                  std::make_shared<std::function<void(std::uint64_t)>>(std::move(resend)));
  }
  return request;
}

void RemoteWrites::scheduleRetry(std::uint64_t request, std::chrono::milliseconds after,
                                 std::chrono::steady_clock::time_point deadline,
                                 std::shared_ptr<std::function<void(std::uint64_t)>> resend) {
  auto it = pending_.find(request);
  if (it == pending_.end() || std::chrono::steady_clock::now() + after >= deadline) return;
  auto retry = std::make_shared<boost::asio::steady_timer>(io_, after);
  it->second.retryTimer = retry;
  retry->async_wait([this, request, after, deadline, resend](const boost::system::error_code& ec) {
    if (ec || !pending_.count(request)) return;
    ++resent_;
    (*resend)(request);
    scheduleRetry(request, after * 2, deadline, resend);
  });
}

void RemoteWrites::complete(std::uint64_t request, const std::optional<Error>& error,
                            std::uint64_t seqno) {
  auto it = pending_.find(request);
  if (it == pending_.end()) return;  // already timed out
  auto pending = std::move(it->second);
  pending_.erase(it);
  pending.timer->cancel();
  if (pending.retryTimer) pending.retryTimer->cancel();
  if (!pending.done) return;
  try {
    pending.done(error, seqno);
  } catch (const std::exception& e) {
    completionThrew_(e.what());
  }
}

void RemoteWrites::onResult(PeisId source, const wire::WriteResult& result) {
  auto pending = pending_.find(result.request);
  // A PEIS on the route may refuse the write for the owner (a frame over
  // its data limit); only the owner can accept it.
  if (pending == pending_.end() || (pending->second.owner != source && result.status == 0)) return;
  if (result.status == 0) return complete(result.request, std::nullopt, result.seqno);
  const auto code = static_cast<ErrorCode>(
      std::min<int>(result.status - 1, static_cast<int>(ErrorCode::Stopped)));
  complete(result.request, Error(code, "PEIS " + std::to_string(source) + ": " + result.message),
           0);
}

void RemoteWrites::failOwner(PeisId owner, const Error& error) {
  std::vector<std::uint64_t> failed;
  for (const auto& [request, pending] : pending_) {
    if (pending.owner == owner) failed.push_back(request);
  }
  for (auto request : failed) complete(request, error, 0);
}

void RemoteWrites::failAll(const Error& error) {
  std::vector<std::uint64_t> all;
  for (const auto& [request, pending] : pending_) all.push_back(request);
  for (auto request : all) complete(request, error, 0);
}

}  // namespace peis
