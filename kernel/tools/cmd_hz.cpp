// peis hz: how often the tuples that match change (rate and jitter), as
// `ros2 topic hz` reports a topic's.
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "command.h"
#include "lookup.h"
#include "output.h"
#include "rate.h"

namespace peis::cli {
namespace {

enum class HzClock { Arrival, Write, User };

HzClock clockOf(const Args& args) {
  const auto text = args.text("--clock").value_or("arrival");
  if (text == "arrival") return HzClock::Arrival;
  if (text == "write") return HzClock::Write;
  if (text == "user") return HzClock::User;
  throw UsageError("--clock needs arrival, write or user, not '" + text + "'");
}

double secondsOf(Timestamp t) { return static_cast<double>(t.time_since_epoch().count()) / 1e6; }

// Shared by the callbacks and the report timer (which may still run after
// run() returned).
struct HzState {
  Pattern pattern;
  HzClock clock = HzClock::Arrival;
  std::size_t window = 100;
  bool json = false;
  std::optional<long long> count;
  std::mutex mu;
  std::map<std::string, RateWindow> keys;  // by "OWNER.KEY"
  std::map<std::string, bool> seenOnce;    // arrival clock: the subscription's first value
  std::set<std::string> changed;           // keys with a new value since the last report
  std::size_t withoutUserTime = 0;
  long long reports = 0;
  bool done = false;
};

void sample(HzState& state, const Tuple& t, Clock::time_point arrival) {
  std::lock_guard lock(state.mu);
  if (state.done) return;
  const auto name = t.fullName();
  double at = 0;
  switch (state.clock) {
    case HzClock::Arrival:
      // The first value is the one the subscription found, not a change
      // made now: it does not start an interval.
      if (!state.seenOnce[name]) {
        state.seenOnce[name] = true;
        return;
      }
      at = std::chrono::duration<double>(arrival.time_since_epoch()).count();
      break;
    case HzClock::Write:
      at = secondsOf(t.ts_write);
      break;
    case HzClock::User:
      if (t.ts_user == kNoTime) {
        ++state.withoutUserTime;
        return;
      }
      at = secondsOf(t.ts_user);
      break;
  }
  state.keys.try_emplace(name, state.window).first->second.add(at);
  state.changed.insert(name);
}

std::string reportLine(const std::string& name, const RateStats& s, bool json) {
  char text[256];
  if (json) {
    std::snprintf(text, sizeof text,
                  ",\"rate_hz\":%.6g,\"min_s\":%.6g,\"max_s\":%.6g,\"std_dev_s\":%.6g,"
                  "\"window\":%zu}",
                  s.rateHz, s.minS, s.maxS, s.stdDevS, s.intervals);
    return "{\"tuple\":" + json::quote(name) + text;
  }
  std::snprintf(text, sizeof text, ": %.3f Hz  min %.4fs  max %.4fs  std dev %.5fs  window %zu",
                s.rateHz, s.minS, s.maxS, s.stdDevS, s.intervals);
  return name + text;
}

// One report: a line per key that changed since the last report and has at
// least one interval.
void report(Kernel& kernel, HzState& state) {
  std::lock_guard lock(state.mu);
  if (state.done) return;
  std::string lines;
  for (const auto& name : state.changed) {
    if (auto stats = state.keys.at(name).stats()) {
      lines += reportLine(name, *stats, state.json) + "\n";
    }
  }
  state.changed.clear();
  if (lines.empty()) return;
  std::cout << lines << std::flush;
  if (state.count && ++state.reports >= *state.count) {
    state.done = true;
    kernel.quit("count reached");
  }
}

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 1, 1, "PATTERN");
  auto state = std::make_shared<HzState>();
  state->clock = clockOf(args);
  state->window = static_cast<std::size_t>(args.number("--window").value_or(100));
  state->json = args.has("--json");
  state->count = args.number("--count");
  const auto interval = args.seconds("--interval").value_or(1.0);
  if (interval < 0.01) throw UsageError("--interval needs at least 0.01 seconds");
  state->pattern = patternOf(kernel, args.positional[0], deadlineIn(3.0));
  const auto self = kernel.id();
  kernel.onChange(state->pattern, [state, self](const Tuple& t) {
    if (t.owner != self) sample(*state, t, Clock::now());
  });
  kernel.subscribe(state->pattern);
  Kernel* k = &kernel;
  kernel.every(std::chrono::milliseconds(static_cast<long long>(interval * 1000)),
               [k, state] { report(*k, *state); });
  const bool quit = runUntilQuitOrTimeout(kernel, args);
  std::lock_guard lock(state->mu);
  state->done = true;
  if (state->withoutUserTime > 0) {
    std::cerr << "peis: " << state->withoutUserTime << " values had no ts_user and were skipped\n";
  }
  return quit || !state->count ? 0 : 1;
}

}  // namespace

Command hzCommand() {
  return {"hz",
          "hz PATTERN",
          "how often matching tuples change: rate, min, max, std dev of intervals",
          "Every --interval (1 s) prints a line for each matching tuple that changed\n"
          "since the last report (and at least twice in all):\n"
          "  OWNER.KEY: R Hz  min A s  max B s  std dev J s  window N\n"
          "over its last --window (100) intervals. --clock: arrival (here, the\n"
          "default), write (the owner's ts_write) or user (ts_user, set by the\n"
          "writer). Stops after --count reports or --timeout.",
          {"--interval", "--window", "--clock", "--count", "--timeout", "--json"},
          true,
          run};
}

}  // namespace peis::cli
