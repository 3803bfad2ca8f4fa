// RemoteWrites: the writes this PEIS sent to other owners and waits on
// (docs/architecture.md, "The path of a remote write"). Each has a request id,
// the owner it went to, a completion and a deadline timer; it completes
// exactly once: with the owner's WriteResult, with Timeout at the deadline,
// or with an error the Kernel gives (the owner gone, no route, shutting
// down). A write not answered is sent again, with the same request id,
// kFirstRetry after it and then at doubling intervals until its deadline
// (a frame lost on a route that changed under it); the owner answers a
// request id it already answered with the same result (docs/protocol.md
// §12). Request ids start at a random value, so a later life of this PEIS
// does not reuse those of an earlier one. Kernel thread only.
#pragma once

#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string_view>

#include "net/wire.h"
#include "peis/kernel.h"

namespace peis {

class RemoteWrites {
 public:
  // `completionThrew` is told when a completion throws (it is caught).
  RemoteWrites(boost::asio::io_context& io, std::function<void(std::string_view)> completionThrew);

  static constexpr std::chrono::milliseconds kFirstRetry{1000};

  // Registers a write to `owner`; it fails with Timeout after `timeout`.
  // `resend` (if any) sends it again while it is not answered. Returns the
  // request id to send in the Write.
  std::uint64_t add(PeisId owner, WriteDone done, std::chrono::milliseconds timeout,
                    std::function<void(std::uint64_t request)> resend = {});
  // Times a write was sent again.
  std::uint64_t resent() const { return resent_; }
  // Completes a pending request (nothing if it completed already).
  void complete(std::uint64_t request, const std::optional<Error>& error, std::uint64_t seqno);
  // An answer: completes the request if `source` is its owner (or refuses
  // it, as a PEIS on the route may).
  void onResult(PeisId source, const wire::WriteResult& result);
  // Fails every request pending at `owner` (it is gone).
  void failOwner(PeisId owner, const Error& error);
  // Fails every pending request (the Kernel is stopping).
  void failAll(const Error& error);

 private:
  struct Pending {
    WriteDone done;
    std::shared_ptr<boost::asio::steady_timer> timer;
    PeisId owner = 0;
    std::shared_ptr<boost::asio::steady_timer> retryTimer;
  };
  void scheduleRetry(std::uint64_t request, std::chrono::milliseconds after,
                     std::chrono::steady_clock::time_point deadline,
                     std::shared_ptr<std::function<void(std::uint64_t)>> resend);
  boost::asio::io_context& io_;
  std::function<void(std::string_view)> completionThrew_;
  std::map<std::uint64_t, Pending> pending_;
  std::uint64_t nextRequest_;
  std::uint64_t resent_ = 0;
};

}  // namespace peis
