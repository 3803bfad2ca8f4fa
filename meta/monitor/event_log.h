// Writes the configurator's events as tuples (`config.event.<n>`, see
// events.h), keeps the last `kept` of them, and logs each on stderr.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>

#include "monitor/events.h"
#include "peis/kernel.h"

namespace peis::meta {

class EventLog {
 public:
  EventLog(Kernel& kernel, std::size_t kept);
  // Records an event now; returns it (with its number and time).
  ConfigEvent record(const std::string& kind, const std::string& text);

 private:
  Kernel& kernel_;
  std::size_t kept_;
  std::mutex mu_;
  std::uint64_t next_ = 1;
};

}  // namespace peis::meta
