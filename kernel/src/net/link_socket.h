// LinkSocket: a link's TCP socket, with a read that does not try the socket
// again when the last read found it drained.
//
// Boost.Asio 1.74's async_read_some first tries a read at once (a
// "speculative" read) and waits on epoll only if it finds nothing. After a
// read that took fewer bytes than it had room for, the socket is empty, and
// the next read's try is a system call that finds nothing: one per frame
// received (2 per round trip). Asio skips the try when the last operation
// on the socket reported itself "done and exhausted" (it waits for the
// next epoll event then, which the socket's edge-triggered registration
// gives for any byte that arrives later, however soon), but its receive
// reports that only at end of file. receiveDrained() is async_read_some
// with one difference: its read reports "exhausted" when it took fewer
// bytes than it had room for. Waiting by async_wait instead costs an
// epoll_ctl per wait (and a wake-up for the socket's writable edge), which
// is why the try is skipped this way (docs/architecture.md, "Reads").
// One case it cannot see: a short read that also consumed the peer's FIN
// (data and end of stream in one arrival) leaves no event for the end of
// stream, so the link learns of the close only from its next write (the
// ping: a reset) or the peer's Leave, which closes the link at once.
// Uses Asio's reactor directly; with another reactor than epoll (or a
// Boost outside 1.74-1.83) it is async_read_some.
#pragma once

#include <sys/socket.h>
#include <sys/uio.h>

#include <array>
#include <boost/asio/ip/tcp.hpp>
#include <boost/version.hpp>
#include <cerrno>
#include <cstddef>
#include <utility>

// The reactor's start_op and post_immediate_completion as Boost 1.74 has
// them (Debian 12's); Boost 1.84 changed them.
#if defined(BOOST_ASIO_HAS_EPOLL) && !defined(BOOST_ASIO_HAS_IO_URING_AS_DEFAULT) && \
    BOOST_VERSION >= 107400 && BOOST_VERSION < 108400
#define PEIS_LINK_DRAINED_READ 1
#include <boost/asio/detail/epoll_reactor.hpp>
#include <boost/asio/detail/reactor_op.hpp>
#include <boost/asio/detail/recycling_allocator.hpp>
#include <boost/asio/detail/socket_ops.hpp>
#else
#define PEIS_LINK_DRAINED_READ 0
#endif

namespace peis::net {

class LinkSocket : public boost::asio::ip::tcp::socket {
 public:
  explicit LinkSocket(boost::asio::ip::tcp::socket&& socket);

  // Reads into `buffers` (at most 3) what has arrived, waiting for it if
  // nothing has; `handler(error_code, bytes)` runs on the socket's
  // io_context as async_read_some's does (never inside this call). With
  // `drainedWhenShort`, the next read waits for epoll without trying first
  // if this one takes fewer bytes than `buffers` hold.
  template <typename Handler, std::size_t N>
  void receiveDrained(const std::array<boost::asio::mutable_buffer, N>& buffers,
                      bool drainedWhenShort, Handler handler);

 private:
#if PEIS_LINK_DRAINED_READ
  template <typename Handler>
  class ReceiveOp;
  template <typename Handler>
  using OpAllocator = boost::asio::detail::recycling_allocator<ReceiveOp<Handler>>;
  // Looked up once: the service registry's lookup takes a lock.
  boost::asio::detail::reactor* reactor_;
#endif
};

#if PEIS_LINK_DRAINED_READ

inline LinkSocket::LinkSocket(boost::asio::ip::tcp::socket&& socket)
    : boost::asio::ip::tcp::socket(std::move(socket)),
      reactor_(&boost::asio::use_service<boost::asio::detail::reactor>(get_executor().context())) {}

template <typename Handler>
class LinkSocket::ReceiveOp : public boost::asio::detail::reactor_op {
 public:
  ReceiveOp(int fd, Handler&& handler)
      : reactor_op(boost::system::error_code(), &perform, &complete),
        fd_(fd),
        handler_(std::move(handler)) {}

  std::array<iovec, 3> parts_{};
  std::size_t count_ = 0, room_ = 0;
  bool drainedWhenShort_ = false;

 private:
  static status perform(reactor_op* base) {
    auto* op = static_cast<ReceiveOp*>(base);
    msghdr message{};
    message.msg_iov = op->parts_.data();
    message.msg_iovlen = op->count_;
    ssize_t n;
    do {
      n = ::recvmsg(op->fd_, &message, 0);  // the socket is non-blocking (start())
    } while (n < 0 && errno == EINTR);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) return not_done;
      op->ec_ = boost::system::error_code(errno, boost::asio::error::get_system_category());
      return done;
    }
    op->bytes_transferred_ = static_cast<std::size_t>(n);
    if (n == 0) {
      op->ec_ = boost::asio::error::eof;
      return done_and_exhausted;
    }
    // Fewer bytes than room: the socket is empty now; the next read waits
    // for epoll without trying first.
    return op->drainedWhenShort_ && op->bytes_transferred_ < op->room_ ? done_and_exhausted : done;
  }

  // Runs the handler (owner set) or only frees the op (the io_context is
  // being destroyed).
  static void complete(void* owner, boost::asio::detail::operation* base,
                       const boost::system::error_code&, std::size_t) {
    auto* op = static_cast<ReceiveOp*>(base);
    Handler handler(std::move(op->handler_));
    const auto ec = op->ec_;
    const auto bytes = op->bytes_transferred_;
    op->~ReceiveOp();
    OpAllocator<Handler>().deallocate(op, 1);  // (Asio's own ops recycle their memory so)
    if (owner) handler(ec, bytes);
  }

  int fd_;
  Handler handler_;
};

template <typename Handler, std::size_t N>
void LinkSocket::receiveDrained(const std::array<boost::asio::mutable_buffer, N>& buffers,
                                bool drainedWhenShort, Handler handler) {
  static_assert(N >= 1 && N <= 3);
  namespace detail = boost::asio::detail;
  auto& impl = impl_.get_implementation();
  auto* op =
      new (OpAllocator<Handler>().allocate(1)) ReceiveOp<Handler>(impl.socket_, std::move(handler));
  for (std::size_t i = 0; i < N; ++i) {
    op->parts_[i] = {buffers[i].data(), buffers[i].size()};
    op->room_ += buffers[i].size();
  }
  op->count_ = N;
  op->drainedWhenShort_ = drainedWhenShort;
  auto& reactor = *reactor_;
  if (impl.socket_ == detail::invalid_socket) {
    op->ec_ = boost::asio::error::bad_descriptor;
    return reactor.post_immediate_completion(op, false);
  }
  if ((impl.state_ & detail::socket_ops::non_blocking) == 0 &&
      !detail::socket_ops::set_internal_non_blocking(impl.socket_, impl.state_, true, op->ec_)) {
    return reactor.post_immediate_completion(op, false);
  }
  reactor.start_op(detail::reactor::read_op, impl.socket_, impl.reactor_data_, op, false, true);
}

#else

inline LinkSocket::LinkSocket(boost::asio::ip::tcp::socket&& socket)
    : boost::asio::ip::tcp::socket(std::move(socket)) {}

template <typename Handler, std::size_t N>
void LinkSocket::receiveDrained(const std::array<boost::asio::mutable_buffer, N>& buffers, bool,
                                Handler handler) {
  async_read_some(buffers, std::move(handler));
}

#endif

}  // namespace peis::net
