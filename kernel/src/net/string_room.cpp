// resizeForOverwrite: see string_room.h. This file alone is compiled as
// C++23 (kernel/CMakeLists.txt) for std::string::resize_and_overwrite; the
// kernel is C++20, and the string's layout is the same in both.
#include "net/string_room.h"

namespace peis::net {

void resizeForOverwrite(std::string& s, std::size_t bytes) {
  s.resize_and_overwrite(bytes, [](char*, std::size_t n) { return n; });
}

}  // namespace peis::net
