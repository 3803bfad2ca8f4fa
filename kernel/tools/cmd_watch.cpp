// peis watch: one line per change or deletion of the tuples that match.
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>

#include "command.h"
#include "lookup.h"
#include "output.h"

namespace peis::cli {
namespace {

enum class Event { Set, Delete };

std::string line(const Tuple& t, Event event, bool json, bool stamps) {
  if (json) {
    auto object = tupleJson(t);
    object.pop_back();
    return object + ",\"event\":\"" + (event == Event::Set ? "set" : "delete") + "\"}";
  }
  std::string text;
  if (stamps) text = clockTime(event == Event::Set ? t.ts_write : systemNow()) + " ";
  return text + (event == Event::Set ? tupleLine(t) : t.fullName() + " deleted");
}

// What the callbacks share with run(); held by the callbacks too, since the
// kernel thread may still deliver after run() returned.
struct WatchState {
  std::vector<Pattern> patterns;
  bool json = false, stamps = false;
  std::optional<long long> count;
  std::mutex mu;
  long long seen = 0;
  bool done = false;
};

void report(Kernel& kernel, WatchState& state, const Tuple& t, Event event) {
  if (t.owner == kernel.id()) return;  // this tool's own kernel tuples
  bool matched = false;
  for (const auto& pattern : state.patterns) matched = matched || pattern.matches(t);
  if (!matched) return;
  std::lock_guard lock(state.mu);
  if (state.done) return;
  std::cout << line(t, event, state.json, state.stamps) << std::endl;
  if (state.count && ++state.seen >= *state.count) {
    state.done = true;
    kernel.quit("count reached");
  }
}

int run(Kernel& kernel, const Args& args) {
  if (args.positional.empty()) throw UsageError("watch needs at least one PATTERN");
  auto state = std::make_shared<WatchState>();
  for (const auto& text : args.positional) {
    state->patterns.push_back(patternOf(kernel, text, deadlineIn(3.0)));
  }
  state->json = args.has("--json");
  state->stamps = args.has("--stamps");
  state->count = args.number("--count");
  // One callback for all patterns, so a tuple two patterns match is one line.
  Kernel* k = &kernel;
  kernel.onChange(Pattern(), [k, state](const Tuple& t) { report(*k, *state, t, Event::Set); });
  kernel.onDelete(Pattern(), [k, state](const Tuple& t) { report(*k, *state, t, Event::Delete); });
  for (const auto& pattern : state->patterns) kernel.subscribe(pattern);
  const bool quit = runUntilQuitOrTimeout(kernel, args);
  std::lock_guard lock(state->mu);
  state->done = true;
  return quit || !state->count ? 0 : 1;
}

}  // namespace

Command watchCommand() {
  return {"watch",
          "watch PATTERN...",
          "one line per change or deletion: OWNER.KEY = VALUE, OWNER.KEY deleted",
          "Prints the current value of every matching tuple, then one line per\n"
          "change ('OWNER.KEY = VALUE') or deletion ('OWNER.KEY deleted'), until\n"
          "stopped, --count lines or --timeout. --stamps starts each line with the\n"
          "owner's write time (for a deletion: when it was seen here). With --json\n"
          "each line is a tuple object with \"event\": \"set\" or \"delete\".",
          {"--count", "--timeout", "--json", "--stamps"},
          true,
          run};
}

}  // namespace peis::cli
