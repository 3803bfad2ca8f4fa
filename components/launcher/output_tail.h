// OutputTail: the last lines a launched program wrote to one of its streams,
// kept for the components.<name>.stdout / .stderr tuples. Bytes arrive in
// any pieces; a line longer than kMaxLineBytes is cut. Pure.
#pragma once

#include <cstddef>
#include <deque>
#include <string>
#include <string_view>

namespace peis::launcher {

class OutputTail {
 public:
  static constexpr std::size_t kMaxLineBytes = 1000;

  explicit OutputTail(std::size_t lines) : lines_(lines) {}

  void append(std::string_view bytes);
  // The last `lines` lines, the unfinished one included, joined by '\n'.
  std::string text() const;
  // True when text() changed since the last take of the flag.
  bool takeChanged() {
    const bool changed = changed_;
    changed_ = false;
    return changed;
  }
  void clear();

 private:
  std::size_t lines_;
  std::deque<std::string> done_;
  std::string partial_;
  bool cut_ = false;  // the partial line was cut: drop the rest of it
  bool changed_ = false;
};

}  // namespace peis::launcher
