// Event tuples of the configurator as text.
#include "monitor/events.h"

#include <charconv>
#include <cstdio>
#include <ctime>

namespace peis::meta {

std::string eventKey(std::uint64_t number) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%010llu", static_cast<unsigned long long>(number));
  return std::string(kEventPrefix) + buf;
}

std::optional<std::uint64_t> eventNumber(std::string_view key) {
  if (key.substr(0, kEventPrefix.size()) != kEventPrefix) return std::nullopt;
  const auto digits = key.substr(kEventPrefix.size());
  std::uint64_t number = 0;
  const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), number);
  if (ec != std::errc() || ptr != digits.data() + digits.size() || digits.empty())
    return std::nullopt;
  return number;
}

std::string ConfigEvent::format() const {
  const auto us = time.time_since_epoch().count();
  const std::time_t seconds = static_cast<std::time_t>(us / 1000000);
  std::tm local{};
  localtime_r(&seconds, &local);
  char clock[32];
  std::snprintf(clock, sizeof clock, "%02d:%02d:%02d.%03d", local.tm_hour, local.tm_min,
                local.tm_sec, static_cast<int>((us / 1000) % 1000));
  char kindColumn[32];
  std::snprintf(kindColumn, sizeof kindColumn, "%-13s", kind.c_str());
  return std::string(clock) + "  " + kindColumn + text;
}

ConfigEvent ConfigEvent::parse(std::uint64_t number, Timestamp time, std::string_view data) {
  ConfigEvent e;
  e.number = number;
  e.time = time;
  const auto space = data.find(' ');
  e.kind = std::string(data.substr(0, space));
  if (space != std::string_view::npos) e.text = std::string(data.substr(space + 1));
  return e;
}

}  // namespace peis::meta
