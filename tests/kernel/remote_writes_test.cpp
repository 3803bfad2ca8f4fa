// Unit tests of RemoteWrites: a write without an answer is sent again with
// the same request id until its answer or its deadline, and completes once.
// Driven by a real io_context, run until the condition holds or a bound.
#include "remote_writes.h"

#include <catch2/catch.hpp>
#include <chrono>
#include <optional>
#include <vector>

#include "support/run_io_until.h"

using namespace std::chrono_literals;
using peis::Error;
using peis::ErrorCode;
using peis::RemoteWrites;
namespace wire = peis::wire;

namespace {

using peis::test::runIoUntil;

}  // namespace

TEST_CASE("remote writes: unanswered, a write is sent again with its request id until answered",
          "[unit][remote-writes]") {
  boost::asio::io_context io;
  RemoteWrites writes(io, [](std::string_view) {});
  std::vector<std::uint64_t> resent;
  int completions = 0;
  std::optional<Error> error;
  std::uint64_t seqno = 0;
  const auto request = writes.add(
      7,
      [&](const std::optional<Error>& e, std::uint64_t s) {
        ++completions;
        error = e;
        seqno = s;
      },
      10s, [&](std::uint64_t r) { resent.push_back(r); });
  CHECK(request != 0);
  // Sent again after RemoteWrites::kFirstRetry, then after twice that.
  REQUIRE(runIoUntil(
      io, [&] { return resent.size() >= 2; }, 8s));
  CHECK(resent == std::vector<std::uint64_t>{request, request});
  CHECK(writes.resent() == 2);
  // The owner's answer (to any copy) completes it once; nothing more is sent.
  writes.onResult(7, wire::WriteResult{request, 0, 4, ""});
  writes.onResult(7, wire::WriteResult{request, 0, 4, ""});
  CHECK(completions == 1);
  CHECK_FALSE(error);
  CHECK(seqno == 4);
  runIoUntil(
      io, [] { return false; }, 4500ms);
  CHECK(resent.size() == 2);
}

TEST_CASE("remote writes: not sent again past the deadline, and ids differ between lives",
          "[unit][remote-writes]") {
  boost::asio::io_context io;
  RemoteWrites writes(io, [](std::string_view) {});
  int resends = 0;
  std::optional<Error> error;
  writes.add(
      7, [&](const std::optional<Error>& e, std::uint64_t) { error = e; }, 1500ms,
      [&](std::uint64_t) { ++resends; });
  REQUIRE(runIoUntil(
      io, [&] { return error.has_value(); }, 5s));
  CHECK(error->code() == ErrorCode::Timeout);
  CHECK(resends == 1);  // at 1 s; 2 s more would pass the deadline
  // A write without a way to send it again is only timed.
  std::optional<Error> plain;
  writes.add(
      7, [&](const std::optional<Error>& e, std::uint64_t) { plain = e; }, 50ms);
  REQUIRE(runIoUntil(
      io, [&] { return plain.has_value(); }, 5s));
  CHECK(writes.resent() == 1);
  // Two lives of a PEIS start their request ids apart.
  RemoteWrites other(io, [](std::string_view) {});
  const auto a = writes.add(7, {}, 1s), b = other.add(7, {}, 1s);
  CHECK(a != b);
  CHECK(a + 1 != b);
}
