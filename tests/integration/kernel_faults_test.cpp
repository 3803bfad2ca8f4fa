// Faults found by using the kernel as a new user would (issue 9), shown
// across real links and processes: a far-future expiry, a big frame in
// transit, and refusals (data limits, a write gate) that must reach the
// writer or the reader as the refuser's reason instead of a time-out. (The
// restarted publisher is in tests/component/publisher_restart_test.cpp.)
// Every test lives in an ecology of its own, waits for conditions with
// generous deadlines and asserts no timing.
#include <arpa/inet.h>
#include <dirent.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <fstream>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "net/wire.h"
#include "peis/error.h"
#include "peis/kernel.h"
#include "support/error_matchers.h"
#include "support/process.h"
#include "support/wait_for.h"

using namespace std::chrono_literals;
using peis::ErrorCode;
using peis::PeisId;
using peis::test::cliArgs;
using peis::test::HasCode;
using peis::test::Process;
using peis::test::uniqueEcology;
using peis::test::waitFor;

namespace {

constexpr auto kDeadline = std::chrono::milliseconds(20s);

// A PEIS of the test process, linked only where `connect` says (no discovery)
// or found by discovery on loopback.
peis::Options options(const std::string& ecology, const std::string& name,
                      std::vector<std::string> connect = {}, bool discovery = false) {
  peis::Options o;
  o.ecology = ecology;
  o.name = name;
  o.discovery = discovery;
  o.connect = std::move(connect);
  return o;
}

std::string localhost(const peis::Kernel& k) { return "127.0.0.1:" + std::to_string(k.port()); }

bool reaches(const peis::Kernel& k, PeisId id) {
  for (const auto& peer : k.peers()) {
    if (peer.id == id) return true;
  }
  return false;
}

// The error a call throws, if it throws a peis::Error.
template <typename F>
std::optional<peis::Error> errorOf(F&& call) {
  try {
    call();
  } catch (const peis::Error& e) {
    return e;
  }
  return std::nullopt;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// CPU time of one thread of this process, by its kernel thread id.
std::chrono::nanoseconds threadCpu(pid_t tid) {
  // The per-thread CPU clock id that pthread_getcpuclockid() builds.
  const clockid_t clock = static_cast<clockid_t>((~static_cast<unsigned>(tid) << 3) | 6);
  timespec ts{};
  if (clock_gettime(clock, &ts) != 0) return {};  // the thread ended
  return std::chrono::seconds(ts.tv_sec) + std::chrono::nanoseconds(ts.tv_nsec);
}

// The CPU time all kernel threads ("peis-kernel") of this process used so far.
std::chrono::nanoseconds kernelThreadsCpu() {
  std::chrono::nanoseconds total{0};
  DIR* dir = opendir("/proc/self/task");
  if (!dir) return total;
  while (const dirent* entry = readdir(dir)) {
    if (entry->d_name[0] == '.') continue;
    std::ifstream comm(std::string("/proc/self/task/") + entry->d_name + "/comm");
    std::string name;
    std::getline(comm, name);
    if (name == "peis-kernel") total += threadCpu(static_cast<pid_t>(std::stol(entry->d_name)));
  }
  closedir(dir);
  return total;
}

// CPU time the kernel threads use while a reference thread spins for
// `reference` of CPU time. A kernel thread that spins too gets about as much
// CPU as the reference, however loaded the host is; an idle one next to none.
std::chrono::nanoseconds kernelCpuWhileSpinning(std::chrono::nanoseconds reference) {
  const auto before = kernelThreadsCpu();
  std::thread spinner([reference] {
    timespec start{}, now{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &start);
    volatile std::uint64_t work = 0;
    do {
      for (int i = 0; i < 100000; ++i) work = work + 1;
      clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
    } while ((now.tv_sec - start.tv_sec) * 1'000'000'000LL + (now.tv_nsec - start.tv_nsec) <
             reference.count());
  });
  spinner.join();
  return kernelThreadsCpu() - before;
}

// A PEIS that is only a TCP socket in this test: it says Hello and then
// sends and reads frames byte by byte as the test wants.
class RawPeer {
 public:
  RawPeer(std::uint16_t port, const std::string& ecology, PeisId id) : id_(id) {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    REQUIRE(connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0);
    peis::wire::Hello hello;
    hello.ecology = ecology;
    hello.id = id;
    hello.incarnation = 1;
    hello.name = "raw";
    std::string out;
    peis::wire::encode(peis::wire::LinkMessage{hello}, out);
    send(out);
  }
  ~RawPeer() { close(fd_); }
  void send(std::string_view bytes) {
    while (!bytes.empty()) {
      const auto n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      REQUIRE(n > 0);
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
  }
  // Reads what has arrived (without waiting) and returns the whole frames
  // among it, decoded.
  std::vector<peis::wire::Message> poll() {
    char buffer[65536];
    while (true) {
      const auto n = recv(fd_, buffer, sizeof buffer, MSG_DONTWAIT);
      if (n <= 0) break;
      in_.append(buffer, static_cast<std::size_t>(n));
    }
    std::vector<peis::wire::Message> frames;
    while (in_.size() >= peis::wire::kFrameHeaderBytes) {
      const auto length = peis::wire::frameLength(in_);
      if (in_.size() < peis::wire::kFrameHeaderBytes + length) break;
      auto decoded = peis::wire::decode(
          std::string_view(in_).substr(peis::wire::kFrameHeaderBytes, length), 1u << 20);
      REQUIRE(decoded.message);
      if (const auto* link = std::get_if<peis::wire::LinkMessage>(&*decoded.message)) {
        if (const auto* ping = std::get_if<peis::wire::Ping>(link)) {  // answered, as a PEIS does
          std::string pong;
          peis::wire::encode(peis::wire::LinkMessage{peis::wire::Pong{ping->nonce}}, pong);
          send(pong);
        }
      }
      frames.push_back(std::move(*decoded.message));
      in_.erase(0, peis::wire::kFrameHeaderBytes + length);
    }
    return frames;
  }
  PeisId id() const { return id_; }

 private:
  int fd_ = -1;
  PeisId id_;
  std::string in_;
};

template <typename T>
bool isLink(const peis::wire::Message& message) {
  const auto* link = std::get_if<peis::wire::LinkMessage>(&message);
  return link && std::holds_alternative<T>(*link);
}

}  // namespace

// (3) A big value in transit: the PEIS receiving it hears bytes all along and
// so never pinged, while the sender heard nothing (its Ping waits behind the
// value) and closed the link as silent. A 50 MB tuple then never arrived.
TEST_CASE("a PEIS that receives a big frame slowly tells the sender it lives",
          "[fault][liveness]") {
  const auto ecology = uniqueEcology("mid-frame");
  auto receiverOptions = options(ecology, "receiver");
  receiverOptions.liveness = 4000ms;  // pings every second; the trickle below takes 10 s or more
  peis::Kernel receiver(receiverOptions);
  const PeisId senderId = 424242;
  peis::wire::Write write;
  write.request = 1;
  write.tuple.owner = receiver.id();
  write.tuple.creator = senderId;
  write.tuple.key = "big";
  write.tuple.data = std::string(8 << 20, 'x');
  const auto frame = peis::wire::encodeFrame(
      peis::wire::RoutedMessage{peis::wire::Envelope{senderId, receiver.id(), 32}, write});
  RawPeer sender(receiver.port(), ecology, senderId);
  REQUIRE(waitFor(
      [&] {
        sender.poll();  // answers the receiver's pings
        return reaches(receiver, sender.id());
      },
      kDeadline));

  // The frame trickles in until the receiver pings (or all of it is sent),
  // the way a slow link carries a big value; then the rest goes at once.
  // Only a Ping made after the frame began counts (the receiver is in this
  // process: its nonce is its steady clock's time).
  const auto began = std::chrono::steady_clock::now().time_since_epoch().count();
  bool pinged = false;
  std::size_t sent = 0;
  while (sent < frame.size() && !pinged) {
    const auto piece = std::min<std::size_t>(4096, frame.size() - sent);
    sender.send(std::string_view(frame).substr(sent, piece));
    sent += piece;
    for (const auto& message : sender.poll()) {
      if (!isLink<peis::wire::Ping>(message)) continue;
      const auto nonce =
          std::get<peis::wire::Ping>(std::get<peis::wire::LinkMessage>(message)).nonce;
      pinged |= static_cast<std::int64_t>(nonce) > began;
    }
    std::this_thread::sleep_for(5ms);  // the pace of a slow link
  }
  CHECK(pinged);
  CHECK(sent < frame.size());  // it pinged while the frame was still arriving
  sender.send(std::string_view(frame).substr(sent));
  bool answered = false;
  REQUIRE(waitFor(
      [&] {
        for (const auto& message : sender.poll()) {
          const auto* routed = std::get_if<peis::wire::RoutedMessage>(&message);
          if (routed && std::holds_alternative<peis::wire::WriteResult>(routed->body)) {
            answered = std::get<peis::wire::WriteResult>(routed->body).status == 0;
            return true;
          }
        }
        return false;
      },
      kDeadline));
  CHECK(answered);
  CHECK(receiver.get("big")->data.size() == (8u << 20));
}

// (2) A ts_expire centuries ahead overflowed the conversion to the timer's
// nanoseconds: the expiry timer fired again without end on the owner and on
// every subscriber.
TEST_CASE("tuples that expire centuries ahead leave the kernel threads idle", "[fault][expiry]") {
  const auto ecology = uniqueEcology("far-expiry");
  peis::Kernel owner(options(ecology, "owner"));
  peis::Kernel subscriber(options(ecology, "subscriber", {localhost(owner)}));
  REQUIRE(waitFor([&] { return reaches(subscriber, owner.id()); }, kDeadline));

  peis::WriteOptions farAhead;
  farAhead.ts_expire = peis::systemNow() + std::chrono::hours(24 * 366 * 400);  // 400 years
  owner.set("far.local", "set by its owner", farAhead);
  subscriber.set(owner.id(), "far.remote", "set by a remote write", farAhead);
  subscriber.set("far.own", "the subscriber's own", farAhead);
  for (const auto* key : {"far.local", "far.remote"}) {
    INFO(key);
    REQUIRE(subscriber.get(owner.id(), key, kDeadline));
    REQUIRE(owner.get(key));
  }

  const auto reference = std::chrono::nanoseconds(300ms);
  const auto used = kernelCpuWhileSpinning(reference);
  INFO("kernel threads used " << used.count() / 1000 << " us of CPU while a spinning thread used "
                              << reference.count() / 1000 << " us");
  CHECK(used < reference / 4);
  CHECK(owner.get("far.local"));
  CHECK(subscriber.get("far.own"));

  // The longest ttl: ts_write + ttl would overflow; it saturates instead of
  // wrapping into the past (the tuple would expire at once).
  peis::WriteOptions longest;
  longest.ttl = std::chrono::microseconds::max();
  subscriber.set(owner.id(), "far.ttl", "the longest ttl", longest);
  const auto tuple = subscriber.get(owner.id(), "far.ttl", kDeadline);
  REQUIRE(tuple);
  CHECK(tuple->ts_expire > peis::systemNow() + std::chrono::hours(24 * 365 * 1000));
  CHECK(kernelCpuWhileSpinning(reference) < reference / 4);
}

// (3) A write refused for its size: the refuser's reason reaches the writer.
TEST_CASE("a write over a data limit fails with the refuser's reason", "[integration][limits]") {
  const auto ecology = uniqueEcology("write-limit");
  auto small = options(ecology, "small");
  small.maxDataBytes = 1000;

  SECTION("the owner refuses, also a frame far over its frame limit") {
    peis::Kernel owner(small);
    peis::Kernel writer(options(ecology, "writer", {localhost(owner)}));
    REQUIRE(waitFor([&] { return reaches(writer, owner.id()); }, kDeadline));
    for (std::size_t size : {5000u, 300000u}) {
      INFO(size << " bytes");
      const auto error = errorOf([&] { writer.set(owner.id(), "big", std::string(size, 'x')); });
      REQUIRE(error);
      INFO(error->what());
      CHECK(error->code() == ErrorCode::TooLarge);
      CHECK(contains(error->what(), "PEIS " + std::to_string(owner.id())));
      CHECK(contains(error->what(), "at most 1000"));
    }
    // The link carried the refusals and lives on.
    CHECK(writer.set(owner.id(), "small", "fits").seqno == 1);
    CHECK(owner.networkStats().garbagePeersDisconnected == 0);
    CHECK(owner.networkStats().malformedFrames == 0);
  }

  SECTION("a relay with a smaller limit answers for the owner") {
    peis::Kernel owner(options(ecology, "owner"));
    small.connect = {localhost(owner)};
    peis::Kernel relay(small);
    peis::Kernel writer(options(ecology, "writer", {localhost(relay)}));
    REQUIRE(waitFor([&] { return reaches(writer, owner.id()); }, kDeadline));
    const auto error = errorOf([&] { writer.set(owner.id(), "big", std::string(5000, 'x')); });
    REQUIRE(error);
    INFO(error->what());
    CHECK(error->code() == ErrorCode::TooLarge);
    CHECK(contains(error->what(), "PEIS " + std::to_string(relay.id())));
    CHECK(contains(error->what(), "at most 1000"));
    CHECK(writer.set(owner.id(), "small", "fits").seqno == 1);
  }
}

// (3) A tuple over a subscriber's limit: the reader learns why it has no value.
TEST_CASE("a tuple over the reader's data limit reads as too large, not as absent",
          "[integration][limits]") {
  const auto ecology = uniqueEcology("read-limit");
  auto small = options(ecology, "small");
  small.maxDataBytes = 1000;
  peis::Kernel owner(options(ecology, "owner"));
  owner.set("big", std::string(5000, 'x'));
  owner.set("huge", std::string(300000, 'x'));
  owner.set("small", "fits");

  auto readsTooLarge = [&](peis::Kernel& reader, PeisId limitedBy) {
    for (const auto* key : {"big", "huge"}) {
      INFO(key);
      const auto error = errorOf([&] { reader.get(owner.id(), key, kDeadline); });
      REQUIRE(error);
      INFO(error->what());
      CHECK(error->code() == ErrorCode::TooLarge);
      CHECK(contains(error->what(), "--peis-max-data"));
      CHECK(contains(error->what(), "PEIS " + std::to_string(limitedBy)));
    }
    // The link lives on: other values arrive, and so does a new value that fits.
    CHECK(reader.get(owner.id(), "small", kDeadline));
    reader.subscribe(peis::Pattern::exact(owner.id(), "big"));
    owner.set("big", "now it fits");
    CHECK(waitFor(
        [&] {
          const auto t = reader.get(owner.id(), "big");
          return t && t->data == "now it fits";
        },
        kDeadline));
  };

  SECTION("the reader's own limit") {
    small.connect = {localhost(owner)};
    peis::Kernel reader(small);
    REQUIRE(waitFor([&] { return reaches(reader, owner.id()); }, kDeadline));
    readsTooLarge(reader, reader.id());
    CHECK(reader.networkStats().malformedFrames == 0);
    CHECK(reader.networkStats().garbagePeersDisconnected == 0);
  }

  SECTION("a relay's limit") {
    small.connect = {localhost(owner)};
    peis::Kernel relay(small);
    peis::Kernel reader(options(ecology, "reader", {localhost(relay)}));
    REQUIRE(waitFor([&] { return reaches(reader, owner.id()); }, kDeadline));
    readsTooLarge(reader, relay.id());
  }
}

// (3) The same through the `peis` command: the owner's refusal of a set and a
// value too large for the command's own limit are reported as such.
TEST_CASE("peis set and peis get report a data limit instead of a time-out",
          "[integration][limits][cli]") {
  const auto ecology = uniqueEcology("cli-limit");
  auto keeperOptions = options(ecology, "keeper", {}, true);
  keeperOptions.maxDataBytes = 1000;
  peis::Kernel keeper(keeperOptions);
  peis::Kernel store(options(ecology, "store", {}, true));
  store.set("big", std::string(50'000'000, 'x'));

  Process set(cliArgs(ecology, {"set", "keeper.value", std::string(5000, 'x')}));
  REQUIRE(set.wait(kDeadline + 10s).has_value());
  INFO(set.describe());
  CHECK(*set.wait(0ms) == 1);
  CHECK(contains(set.err(), "at most 1000"));
  CHECK_FALSE(contains(set.err(), "did not answer"));

  // The default wait, and a limit under the value's 50 MB.
  Process get(cliArgs(ecology, {"get", "store.big", "--peis-max-data", "1048576"}));
  REQUIRE(get.wait(kDeadline + 10s).has_value());
  INFO(get.describe());
  CHECK(*get.wait(0ms) == 1);
  CHECK(contains(get.err(), "50000000 bytes: too large for this PEIS's --peis-max-data"));
  CHECK_FALSE(contains(get.err(), "has no value"));
}

// Other places where an error used to turn into a time-out.
TEST_CASE("remote writes fail with their reason, not with a time-out", "[integration][limits]") {
  const auto ecology = uniqueEcology("write-errors");
  peis::Kernel owner(options(ecology, "owner"));
  auto writerOptions = options(ecology, "writer", {localhost(owner)});
  writerOptions.writeTimeout = 8000ms;  // the owner answers a held write after 6 s
  peis::Kernel writer(writerOptions);
  REQUIRE(waitFor([&] { return reaches(writer, owner.id()); }, kDeadline));

  SECTION("a negative ttl means never, as for a local write (the owner took it for garbage)") {
    peis::WriteOptions negative;
    negative.ttl = -1s;
    const auto error = errorOf([&] { writer.set(owner.id(), "k", "v", negative); });
    CHECK_FALSE(error);
    const auto tuple = owner.get("k");
    REQUIRE(tuple);
    CHECK(tuple->ts_expire == peis::kNoTime);
    CHECK(owner.networkStats().malformedFrames == 0);
  }

  SECTION("a write gate that does not decide in time: the owner says so") {
    std::vector<peis::WriteDecision> held;
    std::mutex mu;
    owner.setWriteGate([&](const peis::Tuple&, PeisId, const peis::WriteDecision& decide) {
      std::lock_guard lock(mu);
      held.push_back(decide);  // a device that never confirms
      return true;
    });
    const auto error = errorOf([&] { writer.set(owner.id(), "lamp", "on"); });
    REQUIRE(error);
    INFO(error->what());
    CHECK(error->code() == ErrorCode::Timeout);
    CHECK(contains(error->what(), "PEIS " + std::to_string(owner.id()) + ": "));
    CHECK(contains(error->what(), "write gate"));
    owner.setWriteGate({});
  }
}

// (5) An owner told to quit (kernel.do-quit) answers the write and leaves:
// its WriteResult and its Leave reach the writer in one read. The writer
// handled the Leave (a link message) at once and the result (a routed one)
// only after the read, so `peis set OWNER.kernel.do-quit yes` reported
// "went away" for a write its owner had applied.
TEST_CASE("a write answered just before its owner leaves succeeds", "[fault][writes]") {
  const auto ecology = uniqueEcology("answer-then-leave");
  peis::Kernel writer(options(ecology, "writer"));
  const PeisId ownerId = 434343;
  RawPeer owner(writer.port(), ecology, ownerId);
  REQUIRE(waitFor(
      [&] {
        owner.poll();  // answers the writer's pings
        return reaches(writer, ownerId);
      },
      kDeadline));

  auto result =
      std::async(std::launch::async, [&] { return writer.set(ownerId, "kernel.do-quit", "yes"); });
  std::optional<peis::wire::Write> write;
  REQUIRE(waitFor(
      [&] {
        for (auto& message : owner.poll()) {
          auto* routed = std::get_if<peis::wire::RoutedMessage>(&message);
          if (routed && std::holds_alternative<peis::wire::Write>(routed->body)) {
            write = std::get<peis::wire::Write>(routed->body);
          }
        }
        return write.has_value();
      },
      kDeadline));
  peis::wire::WriteResult answer;
  answer.request = write->request;
  answer.status = 0;
  answer.seqno = 2;
  auto bytes = peis::wire::encodeFrame(
      peis::wire::RoutedMessage{peis::wire::Envelope{ownerId, writer.id(), 32}, answer});
  std::string leave;
  peis::wire::encode(peis::wire::LinkMessage{peis::wire::Leave{ownerId, 1}}, leave);
  owner.send(bytes + leave);  // one write: the answer, then the leave

  REQUIRE(result.wait_for(kDeadline) == std::future_status::ready);
  const auto written = result.get();  // throws "went away" before the fix
  CHECK(written.data == "yes");
  CHECK(written.seqno == 2);
}
