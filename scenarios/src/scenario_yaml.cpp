// Reading a scenario file; see scenario_yaml.h.
#include "scenario_yaml.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace peis::scenario {
namespace {

// Reads nodes of one file, every error naming file:line.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  Origin at(const YAML::Node& node) const {
    const auto mark = node.Mark();
    return Origin{file_, mark.line >= 0 ? mark.line + 1 : 0};
  }

  [[noreturn]] void fail(const YAML::Node& node, const std::string& why) const {
    throw ScenarioError(at(node).str() + ": " + why);
  }

  void onlyKeys(const YAML::Node& map, const std::set<std::string>& known,
                const std::string& what) const {
    if (!map.IsMap()) fail(map, what + " must be a mapping (key: value)");
    for (const auto& item : map) {
      const auto key = item.first.as<std::string>();
      if (known.count(key)) continue;
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      fail(item.first, "unknown key '" + key + "' in " + what + " (known: " + list + ")");
    }
  }

  std::string text(const YAML::Node& node, const std::string& what) const {
    if (!node.IsScalar()) fail(node, what + " must be a plain value");
    return node.as<std::string>();
  }

  double number(const YAML::Node& node, const std::string& what) const {
    const std::string s = text(node, what);
    std::size_t used = 0;
    double value = 0;
    try {
      value = std::stod(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != s.size() || s.empty() || !std::isfinite(value))
      fail(node, what + " must be a number, not '" + s + "'");
    return value;
  }

  double numberIn(const YAML::Node& node, double low, double high, const std::string& what) const {
    const double value = number(node, what);
    if (value < low || value > high) {
      std::ostringstream range;
      range << low << ".." << high;
      fail(node, what + " must be in " + range.str() + ", not " + text(node, what));
    }
    return value;
  }

  std::vector<std::string> strings(const YAML::Node& node, const std::string& what) const {
    if (!node.IsSequence()) fail(node, what + " must be a list");
    std::vector<std::string> out;
    for (const auto& item : node) out.push_back(text(item, what + " item"));
    return out;
  }

  std::vector<YAML::Node> list(const YAML::Node& node, const std::string& what) const {
    if (!node.IsSequence()) fail(node, what + " must be a list");
    return std::vector<YAML::Node>(node.begin(), node.end());
  }

  // A name usable as a PEIS name and key part.
  std::string name(const YAML::Node& node, const std::string& what) const {
    const std::string s = text(node, what);
    if (s.empty() || s.size() > 64) fail(node, what + " must be 1..64 characters");
    for (const char c : s) {
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_'))
        fail(node, what + " '" + s + "' may hold only letters, digits, '-' and '_'");
    }
    return s;
  }

  std::pair<std::string, std::string> tuple(const YAML::Node& node, const std::string& what) const {
    const std::string s = text(node, what);
    const auto parts = splitTupleName(s);
    if (!parts) fail(node, what + " must be OWNER.KEY, not '" + s + "'");
    return *parts;
  }

 private:
  std::string file_;
};

const std::set<std::string> kTestKeys{"equals", "matches", "above",  "below",
                                      "near",   "present", "changes"};

Selector readSelector(const Reader& r, const YAML::Node& map) {
  Selector s;
  if (map["line"]) s.line = r.text(map["line"], "line");
  if (map["field"]) s.field = static_cast<int>(r.numberIn(map["field"], 1, 1000, "field"));
  return s;
}

// The one test of a condition or of a narration's `when`.
std::optional<Test> readTest(const Reader& r, const YAML::Node& map, const std::string& what) {
  std::optional<Test> found;
  for (const auto& item : map) {
    const auto key = item.first.as<std::string>();
    if (!kTestKeys.count(key)) continue;
    if (found) r.fail(item.first, what + " has two tests (" + key + " and another): give one");
    Test t;
    const YAML::Node& v = item.second;
    if (key == "equals") {
      t.kind = TestKind::Equals;
      t.text = r.text(v, "equals");
    } else if (key == "matches") {
      t.kind = TestKind::Matches;
      t.text = r.text(v, "matches");
    } else if (key == "above") {
      t.kind = TestKind::Above;
      t.number = r.number(v, "above");
    } else if (key == "below") {
      t.kind = TestKind::Below;
      t.number = r.number(v, "below");
    } else if (key == "present") {
      t.kind = TestKind::Present;
      if (r.text(v, "present") != "true") r.fail(v, "present takes true");
    } else if (key == "changes") {
      t.kind = TestKind::Changes;
      if (r.text(v, "changes") != "true") r.fail(v, "changes takes true");
    } else {  // near
      t.kind = TestKind::Near;
      r.onlyKeys(v, {"point", "tuple", "within"}, "near");
      if (!v["within"]) r.fail(v, "near needs within: DISTANCE");
      t.number = r.numberIn(v["within"], 0, 1e6, "within");
      if (v["point"] && v["tuple"]) r.fail(v, "near takes point or tuple, not both");
      if (v["point"]) {
        const auto items = r.list(v["point"], "point");
        if (items.size() != 2) r.fail(v["point"], "point must be [X, Y]");
        t.x = r.number(items[0], "point x");
        t.y = r.number(items[1], "point y");
      } else if (v["tuple"]) {
        std::tie(t.nearOwner, t.nearKey) = r.tuple(v["tuple"], "near tuple");
      } else {
        r.fail(v, "near needs point: [X, Y] or tuple: OWNER.KEY");
      }
    }
    found = t;
  }
  return found;
}

PeisSpec readPeis(const Reader& r, const YAML::Node& n) {
  r.onlyKeys(n, {"name", "id", "program", "tiny", "on", "options", "env", "hosts"}, "a PEIS");
  PeisSpec p;
  p.origin = r.at(n);
  if (!n["name"]) r.fail(n, "a PEIS needs a name");
  p.name = r.name(n["name"], "name");
  if (n["id"]) p.id = static_cast<long long>(r.numberIn(n["id"], 1, 2147483647, "id"));
  if (n["program"]) p.program = r.text(n["program"], "program");
  if (n["tiny"]) p.tiny = r.name(n["tiny"], "tiny");
  if (p.program.empty() == p.tiny.empty())
    r.fail(n, "PEIS '" + p.name + "' needs either program: (a full PEIS) or tiny: (a tiny node)");
  if (n["on"]) {
    if (p.tiny.empty()) r.fail(n["on"], "on: is for tiny nodes only");
    const auto on = r.text(n["on"], "on");
    if (on == "host")
      p.on = TinyTarget::Host;
    else if (on == "avr")
      p.on = TinyTarget::Avr;
    else if (on == "auto")
      p.on = TinyTarget::Auto;
    else
      r.fail(n["on"], "on: takes host, avr or auto, not '" + on + "'");
  }
  if (n["options"]) p.options = r.strings(n["options"], "options");
  if (n["hosts"]) {
    for (const auto& h : r.list(n["hosts"], "hosts")) p.hosts.push_back(r.name(h, "hosts item"));
  }
  if (n["env"]) {
    const auto& env = n["env"];
    if (!env.IsMap()) r.fail(env, "env must be a mapping NAME: VALUE");
    for (const auto& item : env)
      p.env[r.text(item.first, "env name")] = r.text(item.second, "env value");
  }
  if (p.isTiny() && !p.options.empty())
    r.fail(n["options"], "a tiny node takes no options (its id is id:, its environment env:)");
  return p;
}

WorldSpec readWorld(const Reader& r, const YAML::Node& n) {
  r.onlyKeys(n, {"name", "file", "daylight", "options", "hosts"}, "world");
  WorldSpec w;
  w.origin = r.at(n);
  if (n["name"]) w.name = r.name(n["name"], "world name");
  if (n["file"]) w.file = r.text(n["file"], "world file");
  if (n["daylight"]) w.daylight = r.numberIn(n["daylight"], 0, 200000, "daylight");
  if (n["options"]) w.options = r.strings(n["options"], "world options");
  if (n["hosts"]) {
    for (const auto& h : r.list(n["hosts"], "hosts")) w.hosts.push_back(r.name(h, "hosts item"));
  }
  return w;
}

RadioSpec readRadio(const Reader& r, const YAML::Node& n) {
  r.onlyKeys(n, {"loss", "delay_ms", "jitter_ms", "keys"}, "radio");
  RadioSpec radio;
  radio.origin = r.at(n);
  if (n["loss"]) radio.lossPercent = static_cast<int>(r.numberIn(n["loss"], 0, 100, "loss"));
  if (n["delay_ms"])
    radio.delayMs = static_cast<int>(r.numberIn(n["delay_ms"], 0, 10000, "delay_ms"));
  if (n["jitter_ms"])
    radio.jitterMs = static_cast<int>(r.numberIn(n["jitter_ms"], 0, 10000, "jitter_ms"));
  if (n["keys"]) radio.keys = r.text(n["keys"], "keys");
  return radio;
}

Goal readGoal(const Reader& r, const YAML::Node& n) {
  r.onlyKeys(n, {"at", "set", "value"}, "a goal");
  Goal g;
  g.origin = r.at(n);
  if (n["at"]) g.at = r.numberIn(n["at"], 0, 1e7, "at");
  if (!n["set"]) r.fail(n, "a goal needs set: OWNER.KEY");
  if (!n["value"]) r.fail(n, "a goal needs value:");
  std::tie(g.owner, g.key) = r.tuple(n["set"], "set");
  g.value = r.text(n["value"], "value");
  return g;
}

Fault readFault(const Reader& r, const YAML::Node& n) {
  r.onlyKeys(n, {"at", "kill", "stop", "cut", "freeze", "for", "after"}, "a fault");
  Fault f;
  f.origin = r.at(n);
  if (!n["at"]) r.fail(n, "a fault needs at: SECONDS");
  f.at = r.numberIn(n["at"], 0, 1e7, "at");
  int kinds = 0;
  for (const auto& [key, kind] : {std::pair{"kill", FaultKind::Kill},
                                  {"stop", FaultKind::Stop},
                                  {"cut", FaultKind::Cut},
                                  {"freeze", FaultKind::Freeze}}) {
    if (!n[key]) continue;
    ++kinds;
    f.kind = kind;
    f.peis = r.name(n[key], key);
  }
  if (kinds != 1) r.fail(n, "a fault needs exactly one of kill:, stop:, cut:, freeze: (a PEIS)");
  if (n["for"]) {
    if (f.kind == FaultKind::Kill)
      r.fail(n["for"], "kill takes no for: (a killed PEIS stays dead)");
    f.duration = r.numberIn(n["for"], 0.001, 1e7, "for");
  } else if (f.kind == FaultKind::Stop) {
    r.fail(n, "stop needs for: SECONDS (how long the PEIS stays stopped)");
  }
  if (n["after"]) f.after = r.text(n["after"], "after");
  return f;
}

Narration readNarration(const Reader& r, const YAML::Node& n) {
  r.onlyKeys(n, {"tuple", "say", "line", "field", "when"}, "a timeline entry");
  Narration t;
  t.origin = r.at(n);
  if (!n["tuple"]) r.fail(n, "a timeline entry needs tuple: OWNER.KEY");
  if (!n["say"]) r.fail(n, "a timeline entry needs say: WORDS");
  std::tie(t.owner, t.key) = r.tuple(n["tuple"], "tuple");
  t.say = r.text(n["say"], "say");
  t.select = readSelector(r, n);
  if (n["when"]) {
    std::set<std::string> known(kTestKeys);
    r.onlyKeys(n["when"], known, "when");
    t.when = readTest(r, n["when"], "when");
    if (!t.when) r.fail(n["when"], "when needs a test (equals, matches, above, below, near)");
  }
  return t;
}

Condition readCondition(const Reader& r, const YAML::Node& n) {
  std::set<std::string> known{"name", "tuple", "line", "field", "by", "from", "after"};
  known.insert(kTestKeys.begin(), kTestKeys.end());
  r.onlyKeys(n, known, "a success condition");
  Condition c;
  c.origin = r.at(n);
  if (!n["name"]) r.fail(n, "a success condition needs a name");
  c.name = r.text(n["name"], "name");
  if (!n["tuple"]) r.fail(n, "condition '" + c.name + "' needs tuple: OWNER.KEY");
  std::tie(c.owner, c.key) = r.tuple(n["tuple"], "tuple");
  c.select = readSelector(r, n);
  const auto test = readTest(r, n, "condition '" + c.name + "'");
  if (!test)
    r.fail(n, "condition '" + c.name +
                  "' needs a test: equals, matches, above, below, near or present");
  c.test = *test;
  if (n["by"]) c.by = r.numberIn(n["by"], 0, 1e7, "by");
  if (n["from"]) c.from = r.numberIn(n["from"], 0, 1e7, "from");
  if (n["after"]) c.after = r.text(n["after"], "after");
  if (c.by && *c.by < c.from)
    r.fail(n["by"], "condition '" + c.name + "' ends (by) before it starts (from)");
  return c;
}

}  // namespace

std::string Origin::str() const { return line > 0 ? file + ":" + std::to_string(line) : file; }

const char* toString(FaultKind kind) {
  switch (kind) {
    case FaultKind::Kill:
      return "kill";
    case FaultKind::Stop:
      return "stop";
    case FaultKind::Cut:
      return "cut";
    case FaultKind::Freeze:
      return "freeze";
  }
  return "?";
}

std::string Fault::describe() const {
  std::ostringstream out;
  out << toString(kind) << " " << peis << " at " << at;
  if (duration) out << " for " << *duration;
  return out.str();
}

std::vector<std::string> Scenario::knownNames() const {
  std::vector<std::string> names;
  if (world) {
    names.push_back(world->name);
    names.insert(names.end(), world->hosts.begin(), world->hosts.end());
  }
  for (const auto& p : peis) {
    names.push_back(p.name);
    names.insert(names.end(), p.hosts.begin(), p.hosts.end());
  }
  return names;
}

const PeisSpec* Scenario::find(const std::string& name) const {
  for (const auto& p : peis) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

std::optional<std::pair<std::string, std::string>> splitTupleName(std::string_view text) {
  const auto dot = text.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == text.size()) return std::nullopt;
  return std::pair{std::string(text.substr(0, dot)), std::string(text.substr(dot + 1))};
}

Scenario parseScenario(std::string_view text, const std::string& path) {
  Reader r(path);
  YAML::Node root;
  try {
    root = YAML::Load(std::string(text));
  } catch (const YAML::Exception& e) {
    throw ScenarioError(path + ":" + std::to_string(e.mark.line + 1) + ": broken YAML: " + e.msg);
  }
  if (!root || root.IsNull()) throw ScenarioError(path + ": the file is empty");
  r.onlyKeys(root,
             {"name", "description", "speed", "deadline", "start_timeout", "world", "radio", "peis",
              "goals", "faults", "timeline", "success", "trace"},
             "the scenario");
  Scenario s;
  s.path = path;
  s.origin = r.at(root);
  if (!root["name"]) throw ScenarioError(path + ": the scenario needs a name");
  s.name = r.name(root["name"], "name");
  if (root["description"]) s.description = r.text(root["description"], "description");
  if (root["speed"]) s.speed = r.numberIn(root["speed"], 0.1, 100, "speed");
  if (root["deadline"]) s.deadline = r.numberIn(root["deadline"], 0, 1e7, "deadline");
  if (root["start_timeout"])
    s.startTimeout = r.numberIn(root["start_timeout"], 1, 3600, "start_timeout");
  if (root["world"]) s.world = readWorld(r, root["world"]);
  if (root["radio"]) s.radio = readRadio(r, root["radio"]);
  if (root["peis"]) {
    for (const auto& n : r.list(root["peis"], "peis")) s.peis.push_back(readPeis(r, n));
  }
  if (root["goals"]) {
    for (const auto& n : r.list(root["goals"], "goals")) s.goals.push_back(readGoal(r, n));
  }
  if (root["faults"]) {
    for (const auto& n : r.list(root["faults"], "faults")) s.faults.push_back(readFault(r, n));
  }
  if (root["timeline"]) {
    for (const auto& n : r.list(root["timeline"], "timeline"))
      s.timeline.push_back(readNarration(r, n));
  }
  if (root["success"]) {
    for (const auto& n : r.list(root["success"], "success"))
      s.success.push_back(readCondition(r, n));
  }
  if (root["trace"]) {
    const auto& t = root["trace"];
    r.onlyKeys(t, {"skip", "max_data"}, "trace");
    if (t["skip"]) s.trace.skip = r.strings(t["skip"], "skip");
    if (t["max_data"])
      s.trace.maxData = static_cast<std::size_t>(r.numberIn(t["max_data"], 0, 1 << 30, "max_data"));
  }
  return s;
}

Scenario loadScenario(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ScenarioError(path + ": cannot open the scenario file");
  std::ostringstream text;
  text << in.rdbuf();
  return parseScenario(text.str(), path);
}

Fault parseInjectedFault(std::string_view text) {
  std::istringstream in{std::string(text)};
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  const std::string usage = "--inject '" + std::string(text) +
                            "': expected KIND PEIS at SECONDS [for SECONDS], KIND one of kill, "
                            "stop, cut, freeze (e.g. 'stop camera-living-1 at 5 for 8')";
  if ((words.size() != 4 && words.size() != 6) || words[2] != "at" ||
      (words.size() == 6 && words[4] != "for"))
    throw ScenarioError(usage);
  Fault f;
  f.origin = Origin{"--inject", 0};
  if (words[0] == "kill")
    f.kind = FaultKind::Kill;
  else if (words[0] == "stop")
    f.kind = FaultKind::Stop;
  else if (words[0] == "cut")
    f.kind = FaultKind::Cut;
  else if (words[0] == "freeze")
    f.kind = FaultKind::Freeze;
  else
    throw ScenarioError(usage);
  f.peis = words[1];
  auto seconds = [&](const std::string& s) {
    std::size_t used = 0;
    double v = -1;
    try {
      v = std::stod(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != s.size() || !(v >= 0) || !std::isfinite(v)) throw ScenarioError(usage);
    return v;
  };
  f.at = seconds(words[3]);
  if (words.size() == 6) f.duration = seconds(words[5]);
  if (f.kind == FaultKind::Kill && f.duration)
    throw ScenarioError("--inject '" + std::string(text) + "': kill takes no for");
  if (f.kind == FaultKind::Stop && !f.duration)
    throw ScenarioError("--inject '" + std::string(text) + "': stop needs for SECONDS");
  return f;
}

}  // namespace peis::scenario
