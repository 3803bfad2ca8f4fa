// The bridge's way onto the tiny nodes' radio (its base station):
//   - MediumLink: the simulated 802.15.4-like medium (UDP on 127.0.0.1,
//     tiny/medium/host_medium.h) that the host port's nodes are on, as one
//     more node on it;
//   - SerialLink: a serial line carrying frames in the tiny serial framing
//     (tiny_serial.h): a UNIX socket (an emulated MCU's UART, or an XBee
//     gateway) or a tty / pty device. A lost connection is re-opened.
// All calls come from the bridge's one I/O thread.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace peis::bridge {

using Frame = std::vector<std::uint8_t>;

struct LinkStats {
  std::uint64_t framesIn = 0, framesOut = 0, sendErrors = 0, badSerialBytes = 0, reconnects = 0;
};

class RadioLink {
 public:
  virtual ~RadioLink() = default;
  // The descriptor to poll for input, or -1 while disconnected.
  virtual int fd() const = 0;
  // Sends one frame (<= 100 bytes); false if it could not (counted).
  virtual bool send(const Frame& frame) = 0;
  // Takes the frames that arrived, without blocking.
  virtual std::vector<Frame> receive() = 0;
  // Housekeeping (delayed frames, reconnects); returns the ms until it
  // wants to run again.
  virtual int service() = 0;
  virtual std::string describe() const = 0;
  virtual LinkStats stats() const = 0;
};

// "medium:PORT[:SLOTS]" (loss, duplication and delay from the TINY_*
// environment as for the nodes), "unix:PATH", or a device path ("/dev/...",
// with an optional ":BAUD", default 38400). Error(InvalidArgument) if the
// text is none of these; Error(Unreachable) if the medium cannot be joined.
std::unique_ptr<RadioLink> openRadioLink(const std::string& spec);

}  // namespace peis::bridge
