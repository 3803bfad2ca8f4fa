// The last lines of a launched program's stream (see output_tail.h).
#include "launcher/output_tail.h"

namespace peis::launcher {

void OutputTail::append(std::string_view bytes) {
  if (lines_ == 0 || bytes.empty()) return;
  changed_ = true;
  for (const char c : bytes) {
    if (c == '\n') {
      done_.push_back(std::move(partial_));
      partial_.clear();
      cut_ = false;
      if (done_.size() > lines_) done_.pop_front();
      continue;
    }
    if (cut_) continue;
    if (partial_.size() >= kMaxLineBytes) {
      partial_ += "...";
      cut_ = true;
      continue;
    }
    partial_ += c;
  }
}

std::string OutputTail::text() const {
  std::string text;
  // With an unfinished line, it is the last of the `lines_` shown.
  const std::size_t skip = !partial_.empty() && done_.size() >= lines_ ? 1 : 0;
  for (std::size_t i = skip; i < done_.size(); ++i) text += done_[i] + "\n";
  if (!partial_.empty()) return text + partial_;
  if (!text.empty()) text.pop_back();
  return text;
}

void OutputTail::clear() {
  changed_ = changed_ || !done_.empty() || !partial_.empty();
  done_.clear();
  partial_.clear();
  cut_ = false;
}

}  // namespace peis::launcher
