// The two radio links of the bridge (see radio_link.h).
#include "radio_link.h"

#include <errno.h>
#include <fcntl.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <termios.h>
#include <unistd.h>

#include <cstring>

#include "host_medium.h"
#include "peis/error.h"
#include "peis/log.h"
#include "tiny_serial.h"

namespace peis::bridge {
namespace {

std::optional<unsigned long> number(const std::string& text, unsigned long max) {
  if (text.empty() || text.size() > 10) return std::nullopt;
  unsigned long value = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + static_cast<unsigned long>(c - '0');
  }
  if (value > max) return std::nullopt;
  return value;
}

class MediumLink final : public RadioLink {
 public:
  explicit MediumLink(const host_medium_config& config) {
    if (host_medium_open(&medium_, &config) != 0)
      throw Error(ErrorCode::Unreachable,
                  "cannot join the tiny medium on 127.0.0.1:" + std::to_string(config.base_port) +
                      ".." + std::to_string(config.base_port + config.slots - 1) + ": " +
                      std::strerror(errno));
  }
  ~MediumLink() override { host_medium_close(&medium_); }
  int fd() const override { return medium_.fd; }
  bool send(const Frame& frame) override {
    if (frame.empty() || frame.size() > TINY_FRAME_MAX ||
        host_medium_send(&medium_, frame.data(), static_cast<std::uint8_t>(frame.size())) != 0) {
      ++stats_.sendErrors;
      return false;
    }
    ++stats_.framesOut;
    return true;
  }
  std::vector<Frame> receive() override {
    std::vector<Frame> out;
    for (int i = 0; i < 64; ++i) {
      std::uint8_t buf[TINY_FRAME_MAX + 1];
      const int n = host_medium_recv(&medium_, buf, sizeof buf);
      if (n <= 0) break;
      // A datagram over 100 bytes is kept whole enough to be dropped (and
      // counted) by the decoder as too long.
      out.emplace_back(buf, buf + std::min<int>(n, sizeof buf));
      ++stats_.framesIn;
    }
    return out;
  }
  int service() override { return host_medium_flush(&medium_, 1000); }
  std::string describe() const override {
    return "tiny medium 127.0.0.1:" + std::to_string(medium_.cfg.base_port + medium_.slot);
  }
  LinkStats stats() const override { return stats_; }

 private:
  host_medium medium_{};
  LinkStats stats_;
};

speed_t baudConstant(unsigned long baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    default:
      return 0;
  }
}

class SerialLink final : public RadioLink {
 public:
  SerialLink(std::string path, bool unixSocket, speed_t baud)
      : path_(std::move(path)), unixSocket_(unixSocket), baud_(baud) {
    tiny_serial_rx_init(&rx_);
    open();  // a first failure is not fatal: service() retries
  }
  ~SerialLink() override { close(); }
  int fd() const override { return fd_; }
  bool send(const Frame& frame) override {
    std::uint8_t wire[TINY_SERIAL_MAX];
    const auto n =
        frame.size() <= TINY_FRAME_MAX
            ? tiny_serial_encode(wire, frame.data(), static_cast<std::uint8_t>(frame.size()))
            : 0;
    if (n == 0 || fd_ < 0 || !writeAll(wire, n)) {
      ++stats_.sendErrors;
      return false;
    }
    ++stats_.framesOut;
    return true;
  }
  std::vector<Frame> receive() override {
    std::vector<Frame> out;
    if (fd_ < 0) return out;
    std::uint8_t buf[512];
    for (int turn = 0; turn < 16; ++turn) {
      const ssize_t n = ::read(fd_, buf, sizeof buf);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
        log::warn(0, "tinybridge: serial link " + path_ + " " +
                         (n == 0 ? std::string("closed by the other end")
                                 : std::string(std::strerror(errno))) +
                         "; re-opening");
        close();
        break;
      }
      if (n < 0) break;
      for (ssize_t i = 0; i < n; ++i) {
        const auto len = tiny_serial_rx_byte(&rx_, buf[i]);
        if (len > 0) {
          out.emplace_back(rx_.buf, rx_.buf + len);
          ++stats_.framesIn;
        }
      }
      if (n < static_cast<ssize_t>(sizeof buf)) break;
    }
    stats_.badSerialBytes = rx_.bad_length + rx_.bad_checksum;
    return out;
  }
  int service() override {
    if (fd_ >= 0) return 1000;
    if (open()) ++stats_.reconnects;
    return fd_ >= 0 ? 1000 : 200;
  }
  std::string describe() const override {
    return std::string(unixSocket_ ? "serial socket " : "serial device ") + path_;
  }
  LinkStats stats() const override { return stats_; }

 private:
  bool open() {
    int fd = -1;
    if (unixSocket_) {
      sockaddr_un addr{};
      addr.sun_family = AF_UNIX;
      if (path_.size() >= sizeof addr.sun_path) return false;
      std::memcpy(addr.sun_path, path_.c_str(), path_.size() + 1);
      fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
      if (fd < 0) return false;
      if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        ::close(fd);
        return false;
      }
    } else {
      fd = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
      if (fd < 0) return false;
      termios tio{};
      if (::tcgetattr(fd, &tio) == 0) {
        ::cfmakeraw(&tio);
        if (baud_ != 0) {
          ::cfsetispeed(&tio, baud_);
          ::cfsetospeed(&tio, baud_);
        }
        (void)::tcsetattr(fd, TCSANOW, &tio);
      }
    }
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
    fd_ = fd;
    tiny_serial_rx_init(&rx_);
    log::info(0, "tinybridge: serial link " + path_ + " open");
    return true;
  }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  // Writes a whole framed frame (at most 103 bytes); waits briefly for room.
  bool writeAll(const std::uint8_t* data, std::size_t n) {
    std::size_t done = 0;
    for (int tries = 0; done < n && tries < 200; ++tries) {
      const ssize_t w = ::write(fd_, data + done, n - done);
      if (w > 0) {
        done += static_cast<std::size_t>(w);
      } else if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) {
        ::usleep(1000);  // the UART drains at its baud rate
      } else {
        close();
        return false;
      }
    }
    return done == n;
  }

  std::string path_;
  bool unixSocket_;
  speed_t baud_;
  int fd_ = -1;
  tiny_serial_rx rx_{};
  LinkStats stats_;
};

}  // namespace

std::unique_ptr<RadioLink> openRadioLink(const std::string& spec) {
  auto bad = [&](const std::string& why) {
    return Error(ErrorCode::InvalidArgument, "radio link '" + spec + "': " + why +
                                                 " (use medium:PORT[:SLOTS], unix:PATH or "
                                                 "/dev/DEVICE[:BAUD])");
  };
  if (spec.rfind("medium:", 0) == 0) {
    host_medium_config config;
    host_medium_config_from_env(&config);
    const auto rest = spec.substr(7);
    const auto colon = rest.find(':');
    const auto port = number(rest.substr(0, colon), 65535);
    if (!port || *port == 0) throw bad("the medium's base port must be 1..65535");
    config.base_port = static_cast<unsigned>(*port);
    if (colon != std::string::npos) {
      const auto slots = number(rest.substr(colon + 1), 64);
      if (!slots || *slots < 2) throw bad("the medium's slot count must be 2..64");
      config.slots = static_cast<unsigned>(*slots);
    }
    if (config.slots < 2 || config.slots > 64) throw bad("TINY_MEDIUM_SLOTS must be 2..64");
    if (config.base_port + config.slots - 1 > 65535) throw bad("the port range passes 65535");
    return std::make_unique<MediumLink>(config);
  }
  if (spec.rfind("unix:", 0) == 0) {
    if (spec.size() == 5) throw bad("no socket path");
    return std::make_unique<SerialLink>(spec.substr(5), true, 0);
  }
  if (spec.rfind("/", 0) == 0) {
    auto path = spec;
    speed_t baud = B38400;
    const auto colon = spec.rfind(':');
    if (colon != std::string::npos) {
      const auto value = number(spec.substr(colon + 1), 4000000);
      baud = value ? baudConstant(*value) : 0;
      if (baud == 0) throw bad("unsupported baud rate");
      path = spec.substr(0, colon);
    }
    return std::make_unique<SerialLink>(path, false, baud);
  }
  throw bad("unknown kind of link");
}

}  // namespace peis::bridge
