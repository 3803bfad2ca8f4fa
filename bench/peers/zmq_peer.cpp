// ZeroMQ as a benchmark peer, through libzmq's C API: PUB/SUB over TCP on
// loopback, a ping-pong between two processes (a PUB and a SUB each way) and
// a one-way stream to one subscriber. The publisher never drops
// (ZMQ_XPUB_NODROP: the sender waits for the subscriber), so what is
// delivered is what was sent.
#include <zmq.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "../child_process.h"
#include "peers.h"

namespace peis::bench {
namespace {

using namespace std::chrono_literals;

constexpr std::uint64_t kStop = ~0ull;

struct Socket {
  void* handle;
  Socket(void* context, int type) : handle(zmq_socket(context, type)) {
    if (!handle) {
      std::fprintf(stderr, "zmq: cannot create a socket: %s\n", zmq_strerror(zmq_errno()));
      std::exit(1);
    }
    int zero = 0;
    zmq_setsockopt(handle, ZMQ_LINGER, &zero, sizeof zero);
  }
  ~Socket() { zmq_close(handle); }
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;

  // Binds to an ephemeral port on loopback and returns it.
  int bindLoopback() {
    if (zmq_bind(handle, "tcp://127.0.0.1:*") != 0) return -1;
    char endpoint[256];
    std::size_t size = sizeof endpoint;
    zmq_getsockopt(handle, ZMQ_LAST_ENDPOINT, endpoint, &size);
    return std::atoi(std::strrchr(endpoint, ':') + 1);
  }
  void connectLoopback(int port) {
    zmq_connect(handle, ("tcp://127.0.0.1:" + std::to_string(port)).c_str());
  }
  void subscribeAll() { zmq_setsockopt(handle, ZMQ_SUBSCRIBE, "", 0); }
};

struct Context {
  void* handle = zmq_ctx_new();
  ~Context() { zmq_ctx_term(handle); }
};

// A message: the sequence number in its first 8 bytes (of at least 8).
std::uint64_t seqnoOf(const void* data, std::size_t size) {
  std::uint64_t seqno = 0;
  if (size >= 8) std::memcpy(&seqno, data, 8);
  return seqno;
}

// Sends without ever dropping: with ZMQ_XPUB_NODROP a full queue says EAGAIN.
void sendAll(void* socket, const std::vector<char>& message) {
  while (zmq_send(socket, message.data(), message.size(), ZMQ_DONTWAIT) < 0) {
    if (zmq_errno() != EAGAIN) return;
    std::this_thread::yield();
  }
}

bool receiveWithin(void* socket, std::vector<char>& buffer, std::chrono::milliseconds timeout,
                   std::uint64_t& seqno) {
  zmq_pollitem_t item{socket, 0, ZMQ_POLLIN, 0};
  if (zmq_poll(&item, 1, static_cast<long>(timeout.count())) <= 0) return false;
  const int got = zmq_recv(socket, buffer.data(), buffer.size(), 0);
  if (got < 0) return false;
  seqno = seqnoOf(buffer.data(), static_cast<std::size_t>(got));
  return true;
}

}  // namespace

int zmqEchoRole(int parentPort) {
  Context context;
  Socket in(context.handle, ZMQ_SUB), out(context.handle, ZMQ_PUB);
  in.subscribeAll();
  in.connectLoopback(parentPort);
  std::printf("%d\n", out.bindLoopback());
  std::fflush(stdout);
  zmq_msg_t message;
  zmq_msg_init(&message);
  while (zmq_msg_recv(&message, in.handle, 0) >= 0) {
    if (zmq_msg_send(&message, out.handle, 0) < 0) break;
  }
  return 0;
}

int zmqSinkRole(int parentPort) {
  Context context;
  Socket in(context.handle, ZMQ_SUB);
  int deepQueue = 100000;
  zmq_setsockopt(in.handle, ZMQ_RCVHWM, &deepQueue, sizeof deepQueue);
  in.subscribeAll();
  in.connectLoopback(parentPort);
  std::vector<char> buffer(1 << 20);
  std::uint64_t count = 0, last = 0;
  std::int64_t lastAt = 0;
  bool announced = false;
  while (true) {
    const int got = zmq_recv(in.handle, buffer.data(), buffer.size(), 0);
    if (got < 0) return 1;
    const auto seqno = seqnoOf(buffer.data(), static_cast<std::size_t>(got));
    if (seqno == 0) {  // the publisher's hello: we are subscribed
      if (!announced) std::printf("ready\n"), std::fflush(stdout);
      announced = true;
    } else if (seqno == kStop) {
      break;
    } else if (seqno > last) {
      last = seqno;
      ++count;
      lastAt = nowMicros();
    }
  }
  std::printf("%llu %lld\n", static_cast<unsigned long long>(count),
              static_cast<long long>(lastAt));
  std::fflush(stdout);
  return 0;
}

Percentiles zmqRoundTrip(std::size_t bytes, int count) {
  Context context;
  Socket out(context.handle, ZMQ_PUB), in(context.handle, ZMQ_SUB);
  const int port = out.bindLoopback();
  Child echo({"--role", "zmq-echo", "--port", std::to_string(port)});
  in.subscribeAll();
  in.connectLoopback(std::stoi(echo.line()));
  std::vector<char> message(std::max<std::size_t>(bytes, 8), 'x');
  std::vector<char> back(message.size() + 64);
  std::vector<double> micros;
  // A subscription takes a moment to reach the publisher (ZeroMQ's "slow
  // joiner"): the first rounds are repeated until answered.
  for (int i = 0; i < count + 50; ++i) {
    const auto seqno = static_cast<std::uint64_t>(i) + 1;
    std::memcpy(message.data(), &seqno, 8);
    const auto start = Clock::now();
    const auto giveUp = start + 10s;
    bool answered = false;
    while (!answered && Clock::now() < giveUp) {
      zmq_send(out.handle, message.data(), message.size(), 0);
      std::uint64_t got = 0;
      while (receiveWithin(in.handle, back, i < 50 ? 100ms : 10000ms, got)) {
        if (got == seqno) {
          answered = true;
          break;
        }
      }
    }
    if (!answered) return {};
    if (i >= 50) micros.push_back(microsSince(start));
  }
  return percentiles(micros);
}

StreamResult zmqStream(std::size_t bytes, double seconds) {
  Context context;
  Socket out(context.handle, ZMQ_PUB);
  int one = 1, deepQueue = 100000;  // queues deep enough to stream without stalls
  zmq_setsockopt(out.handle, ZMQ_XPUB_NODROP, &one, sizeof one);
  zmq_setsockopt(out.handle, ZMQ_SNDHWM, &deepQueue, sizeof deepQueue);
  const int port = out.bindLoopback();
  Child sink({"--role", "zmq-sink", "--port", std::to_string(port)});
  std::vector<char> message(std::max<std::size_t>(bytes, 8), 'x');
  // Hello (seqno 0) until the sink says it receives them.
  std::atomic<bool> ready{false};
  std::thread hello([&] {
    std::vector<char> greeting(8, 0);
    for (int i = 0; i < 10000 && !ready; ++i) {
      zmq_send(out.handle, greeting.data(), greeting.size(), ZMQ_DONTWAIT);
      std::this_thread::sleep_for(1ms);
    }
  });
  const bool sinkReady = sink.line() == "ready";
  ready = true;
  hello.join();
  StreamResult result;
  if (!sinkReady) return result;
  const auto start = nowMicros();
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  std::uint64_t seqno = 0;
  while (Clock::now() < until) {
    for (int i = 0; i < 64; ++i) {
      ++seqno;
      std::memcpy(message.data(), &seqno, 8);
      sendAll(out.handle, message);
    }
  }
  result.written = seqno;
  std::memcpy(message.data(), &kStop, 8);
  sendAll(out.handle, message);
  unsigned long long delivered = 0;
  long long lastAt = 0;
  if (std::sscanf(sink.line().c_str(), "%llu %lld", &delivered, &lastAt) != 2) return result;
  result.delivered = delivered;
  if (lastAt > start)
    result.deliveredPerSecond =
        static_cast<double>(delivered) / (static_cast<double>(lastAt - start) / 1e6);
  return result;
}

}  // namespace peis::bench
