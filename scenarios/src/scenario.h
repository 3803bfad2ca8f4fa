// The scenario model: what a scenario file declares (docs/scenarios.md) —
// the world, the PEIS with their programs and options, timed goals, faults,
// the timeline's narration and the success conditions — as plain values.
// scenario_yaml.cpp reads it from YAML (file:line errors); scenario_check.cpp
// validates it against the programs that exist; runner.cpp runs it.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace peis::scenario {

// Where something was declared, for error messages: "photo-sofa.yaml:12".
struct Origin {
  std::string file;
  int line = 0;  // 1-based; 0 = unknown
  std::string str() const;
};

// Where a tiny node runs: on the host radio simulation, on the emulated
// ATmega128 (simavr), or on the emulator when its tools are built, else the host.
enum class TinyTarget { Host, Avr, Auto };

struct PeisSpec {
  Origin origin;
  std::string name;             // the PEIS name (--peis-name), unique in the scenario
  std::optional<long long> id;  // --peis-id (full PEIS) or --id (tiny node)
  std::string program;          // a full PEIS program (`peis-navigation`), or empty for a tiny node
  std::string tiny;             // a tiny device program (`plant` -> tiny-plant, plant.elf)
  TinyTarget on = TinyTarget::Host;
  std::vector<std::string> options;        // extra arguments, before substitution
  std::map<std::string, std::string> env;  // extra environment, before substitution
  std::vector<std::string> hosts;          // other PEIS the process hosts (a world's drivers)
  bool isTiny() const { return !tiny.empty(); }
};

// The simulated home: run as `peis-sim-world`, the scenario's clock and the
// source of the top-down picture.
struct WorldSpec {
  Origin origin;
  std::string name = "world";
  std::string file;                // empty: peis-sim-world's default (the PEIS-Home)
  std::optional<double> daylight;  // physics.daylight written once every PEIS joined
  std::vector<std::string> options;
  std::vector<std::string> hosts;  // the driver PEIS it hosts (`Pippi-base`)
};

// The simulated 802.15.4 medium the tiny nodes and bridges share.
struct RadioSpec {
  Origin origin;
  int lossPercent = 0, delayMs = 0, jitterMs = 0;
  std::string keys;  // key-registry seed for the gateways of emulated nodes (before substitution)
};

// A tuple write at a scenario time: a person's request, a task, the weather.
struct Goal {
  Origin origin;
  double at = 0;           // scenario seconds
  std::string owner, key;  // `Astrid`, `task`
  std::string value;       // before substitution
};

enum class FaultKind { Kill, Stop, Cut, Freeze };
const char* toString(FaultKind kind);

struct Fault {
  Origin origin;
  double at = 0;
  FaultKind kind = FaultKind::Kill;
  std::string peis;                // the scenario PEIS name it hits
  std::optional<double> duration;  // `for`: Stop, Cut, Freeze end after it (Kill: never)
  // `after`: a success condition that must have held first (the fault then
  // hits at `at` or as soon as it held, whichever is later): a fault meant
  // for a phase of the run hits in it however fast the machine is.
  std::string after;
  std::string describe() const;  // "stop camera-living-1 at 5 for 8"
};

// Which part of a tuple's value a condition or narration looks at.
struct Selector {
  std::string line;          // the line starting with these words (`robot Pippi`), the rest of it
  std::optional<int> field;  // the N-th whitespace-separated word (1-based)
  bool empty() const { return line.empty() && !field; }
};

// Changes: a new value arrives (after the condition was armed).
enum class TestKind { Equals, Matches, Above, Below, Near, Present, Changes };

struct Test {
  TestKind kind = TestKind::Present;
  std::string text;                // Equals: the value; Matches: the regular expression
  double number = 0;               // Above, Below: the bound; Near: the distance
  std::optional<double> x, y;      // Near: a point
  std::string nearOwner, nearKey;  // Near: or the first two numbers of a tuple (`world.place.bed`)
};

struct Condition {
  Origin origin;
  std::string name;
  std::string owner, key;  // the tuple
  Selector select;
  Test test;
  std::optional<double> by;  // deadline, scenario seconds (else the scenario's)
  double from = 0;           // tested only from this scenario time on
  std::string after;         // another condition that must have held first
};

// A line the timeline prints when a tuple changes (and, with `when`, only
// when the test holds).
struct Narration {
  Origin origin;
  std::string owner, key;
  std::string say;  // words; `{value}` is replaced by the (selected) value
  Selector select;
  std::optional<Test> when;
};

struct TraceSpec {
  std::vector<std::string> skip;  // OWNER.KEY globs never subscribed (camera images)
  std::size_t maxData = 1 << 20;  // larger values are recorded by size only
};

struct Scenario {
  Origin origin;
  std::string path;  // the file as given
  std::string name, description;
  double speed = 1;
  std::optional<double> deadline;  // default of every condition's `by`
  double startTimeout = 60;        // real seconds for every PEIS to join
  std::optional<WorldSpec> world;
  std::optional<RadioSpec> radio;
  std::vector<PeisSpec> peis;
  std::vector<Goal> goals;
  std::vector<Fault> faults;
  std::vector<Narration> timeline;
  std::vector<Condition> success;
  TraceSpec trace;

  // Every PEIS name the scenario knows: its PEIS, the world and what they host.
  std::vector<std::string> knownNames() const;
  const PeisSpec* find(const std::string& name) const;
};

}  // namespace peis::scenario
