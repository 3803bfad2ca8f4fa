// Small helpers of the tuple value types and error codes.
#include "peis/tuple.h"

#include "peis/error.h"
#include "peis/key.h"

namespace peis {

std::string Tuple::fullName() const { return peis::fullName(owner, key); }
std::string TupleRef::str() const { return peis::fullName(owner, key); }

const char* toString(ErrorCode code) {
  switch (code) {
    case ErrorCode::InvalidKey:
      return "invalid key";
    case ErrorCode::InvalidName:
      return "invalid name";
    case ErrorCode::AmbiguousName:
      return "ambiguous name";
    case ErrorCode::InvalidArgument:
      return "invalid argument";
    case ErrorCode::TooLarge:
      return "too large";
    case ErrorCode::NotOwner:
      return "not owner";
    case ErrorCode::Conflict:
      return "conflict";
    case ErrorCode::NotFound:
      return "not found";
    case ErrorCode::Unreachable:
      return "unreachable";
    case ErrorCode::Timeout:
      return "timeout";
    case ErrorCode::Refused:
      return "refused";
    case ErrorCode::WouldDeadlock:
      return "would deadlock";
    case ErrorCode::InvalidConfig:
      return "invalid configuration";
    case ErrorCode::Stopped:
      return "stopped";
  }
  return "unknown error";
}

}  // namespace peis
