// The configurator's event tuples.
#include "monitor/event_log.h"

#include "peis/log.h"

namespace peis::meta {

EventLog::EventLog(Kernel& kernel, std::size_t kept) : kernel_(kernel), kept_(kept) {
  // A configurator restarted with the same id continues the numbering of
  // what is still there.
  for (const auto& t : kernel_.find(Pattern(std::string(kEventPrefix) + "*", kernel_.id()))) {
    if (auto n = eventNumber(t.key); n && *n >= next_) next_ = *n + 1;
  }
}

ConfigEvent EventLog::record(const std::string& kind, const std::string& text) {
  std::lock_guard lock(mu_);
  ConfigEvent event;
  event.number = next_++;
  event.time = systemNow();
  event.kind = kind;
  event.text = text;
  WriteOptions options;
  options.ts_user = event.time;
  kernel_.set(eventKey(event.number), event.data(), options);
  if (event.number > kept_) kernel_.erase(eventKey(event.number - kept_));
  log::info(kernel_.id(), "configurator: " + kind + " " + text);
  return event;
}

}  // namespace peis::meta
