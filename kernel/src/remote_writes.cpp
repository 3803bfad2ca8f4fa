// RemoteWrites: pending writes to other owners; see remote_writes.h.
#include "remote_writes.h"

#include <algorithm>
#include <vector>

namespace peis {

RemoteWrites::RemoteWrites(boost::asio::io_context& io,
                           std::function<void(std::string_view)> completionThrew)
    : io_(io), completionThrew_(std::move(completionThrew)) {}

std::uint64_t RemoteWrites::add(PeisId owner, WriteDone done, std::chrono::milliseconds timeout) {
  const auto request = nextRequest_++;
  auto timer = std::make_shared<boost::asio::steady_timer>(io_, timeout);
  pending_[request] = Pending{std::move(done), timer, owner};
  timer->async_wait([this, request, owner, timeout](const boost::system::error_code& ec) {
    if (ec) return;
    complete(request,
             Error(ErrorCode::Timeout, "PEIS " + std::to_string(owner) + " did not answer within " +
                                           std::to_string(timeout.count()) + " ms"),
             0);
  });
  return request;
}

void RemoteWrites::complete(std::uint64_t request, const std::optional<Error>& error,
                            std::uint64_t seqno) {
  auto it = pending_.find(request);
  if (it == pending_.end()) return;  // already timed out
  auto pending = std::move(it->second);
  pending_.erase(it);
  pending.timer->cancel();
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
