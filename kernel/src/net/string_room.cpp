// resizeForOverwrite: see string_room.h. This file alone is compiled as
// C++23 (kernel/CMakeLists.txt) for std::string::resize_and_overwrite; the
// kernel is C++20, and the string's layout is the same in both.
#include "net/string_room.h"

namespace peis::net {

void resizeForOverwrite(std::string& s, std::size_t bytes) {
  // The size is `bytes`, not the operation's `n`: libstdc++ 12 passes the
  // capacity it grew to (up to twice the old one) as `n` when it had to grow,
  // and a string sized to that would carry bytes nobody wrote.
  s.resize_and_overwrite(bytes, [bytes](char*, std::size_t) { return bytes; });
}

}  // namespace peis::net
