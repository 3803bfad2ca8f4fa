// The one exception type of the kernel API. Every failure carries a code a
// program can branch on and a message a person can act on.
#pragma once

#include <stdexcept>
#include <string>

namespace peis {

enum class ErrorCode {
  InvalidKey,       // malformed key or pattern
  InvalidName,      // malformed or unknown PEIS name
  AmbiguousName,    // a name that more than one PEIS carries
  InvalidArgument,  // any other malformed argument (options, values)
  TooLarge,         // data over the PEIS's data limit
  NotOwner,         // an operation only the owner may perform
  Conflict,         // a conditional write whose condition no longer holds
  NotFound,         // the tuple or PEIS does not exist
  Unreachable,      // the owner cannot be reached
  Timeout,          // a deadline passed
  Refused,          // the owner refused the operation
  WouldDeadlock,    // a blocking call made on the kernel thread
  InvalidConfig,    // broken descriptor or configuration file
  Stopped,          // the kernel has shut down
};

const char* toString(ErrorCode code);

class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ErrorCode code() const { return code_; }

 private:
  ErrorCode code_;
};

}  // namespace peis
