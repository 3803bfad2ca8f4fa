// The configurator's events, as text. Each event is a tuple of the
// configurator, `config.event.<number>` (the number zero-padded to ten
// digits, so key order is event order), with the data `<kind> <text>` and
// the event's time as its `ts_user`. The last few hundred are kept.
// `peis config events [--follow]` prints them (docs/configuration.md, "Events").
//
// Kinds: started, active, standby, goals, pending, failure, replanned,
// deployed, deploy-failed, gave-up, recovered, kept, drift.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "peis/types.h"

namespace peis::meta {

inline constexpr std::string_view kEventPrefix = "config.event.";

std::string eventKey(std::uint64_t number);
std::optional<std::uint64_t> eventNumber(std::string_view key);

struct ConfigEvent {
  std::uint64_t number = 0;
  Timestamp time{};
  std::string kind;
  std::string text;
  std::string data() const { return kind + " " + text; }
  // `12:00:01.250  failure      cam2/camera/capture: PEIS cam2 is gone` (local time).
  std::string format() const;
  static ConfigEvent parse(std::uint64_t number, Timestamp time, std::string_view data);
};

}  // namespace peis::meta
