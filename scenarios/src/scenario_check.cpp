// Validating a scenario; see scenario_check.h.
#include "scenario_check.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <regex>
#include <set>

#include "launch_plan.h"
#include "program_finder.h"

namespace peis::scenario {
namespace {

bool isNumber(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::string programName(const std::string& program) {
  return std::filesystem::path(program).filename().string();
}

class Checker {
 public:
  Checker(const Scenario& s, const ProgramFinder& finder, const std::vector<std::string>& without)
      : s_(s), finder_(finder), without_(without) {
    for (const auto& name : s.knownNames()) names_.insert(name);
    for (const auto& p : s.peis) {
      if (p.id) ids_.insert(std::to_string(*p.id));
    }
  }

  std::vector<std::string> errors;

  void fail(const Origin& o, const std::string& why) { errors.push_back(o.str() + ": " + why); }

  void knownOwner(const Origin& o, const std::string& owner, const std::string& what) {
    if (names_.count(owner) || (isNumber(owner) && ids_.count(owner))) return;
    std::string list;
    for (const auto& n : names_) list += (list.empty() ? "" : ", ") + n;
    fail(o, what + " names PEIS '" + owner +
                "', which the scenario does not have (it has: " + list + ")");
  }

  void names() {
    std::map<std::string, Origin> seen;
    std::map<long long, std::string> ids;
    auto add = [&](const std::string& name, const Origin& o) {
      if (const auto it = seen.find(name); it != seen.end())
        fail(o, "PEIS name '" + name + "' is used twice (also at " + it->second.str() + ")");
      seen.emplace(name, o);
    };
    if (s_.world) {
      add(s_.world->name, s_.world->origin);
      for (const auto& h : s_.world->hosts) add(h, s_.world->origin);
    }
    for (const auto& p : s_.peis) {
      add(p.name, p.origin);
      for (const auto& h : p.hosts) add(h, p.origin);
      if (p.id) {
        if (const auto it = ids.find(*p.id); it != ids.end())
          fail(p.origin,
               "id " + std::to_string(*p.id) + " is used twice (also by '" + it->second + "')");
        ids.emplace(*p.id, p.name);
      }
    }
  }

  void goals() {
    for (const auto& g : s_.goals) knownOwner(g.origin, g.owner, "goal");
  }

  void faults(const std::vector<Fault>& list) {
    for (const auto& f : list) {
      if (!f.after.empty() && std::none_of(s_.success.begin(), s_.success.end(),
                                           [&](const Condition& c) { return c.name == f.after; }))
        fail(f.origin,
             "fault '" + f.describe() + "' comes after '" + f.after + "', which is no condition");
      // A fault hits a process the runner starts: the world or a declared PEIS.
      const bool world = s_.world && f.peis == s_.world->name;
      const PeisSpec* p = s_.find(f.peis);
      if (!world && !p) {
        knownOwner(f.origin, f.peis, "fault '" + f.describe() + "'");
        if (names_.count(f.peis))
          fail(f.origin, "fault '" + f.describe() + "': '" + f.peis +
                             "' is hosted by another process; name that process");
        continue;
      }
      if (std::find(without_.begin(), without_.end(), f.peis) != without_.end()) {
        fail(f.origin, "fault '" + f.describe() + "' hits '" + f.peis + "', which is left out");
        continue;
      }
      if (f.kind == FaultKind::Cut) {
        const bool tinyOnRadio = p && p->isTiny() && resolveTarget(*p, finder_) == TinyTarget::Host;
        bool bridgeOnRadio = false;
        if (p && !p->isTiny()) {
          for (const auto& o : p->options) bridgeOnRadio |= o.find("{radio") != std::string::npos;
        }
        if (!tinyOnRadio && !bridgeOnRadio)
          fail(f.origin, "fault '" + f.describe() +
                             "': a cut takes a PEIS off the simulated radio, and '" + f.peis +
                             "' is not on it (a tiny node on the host radio, or a PEIS whose "
                             "options name {radio}); to silence a full PEIS, stop it");
      }
      if (f.kind == FaultKind::Freeze) {
        const auto& freezable = freezablePrograms();
        const std::string program = p ? programName(p->program) : "peis-sim-world";
        if (std::find(freezable.begin(), freezable.end(), program) == freezable.end()) {
          std::string list;
          for (const auto& n : freezable) list += (list.empty() ? "" : ", ") + n;
          fail(f.origin, "fault '" + f.describe() +
                             "': a freeze holds a simulated sensor's "
                             "readings, and '" +
                             f.peis + "' runs " + program + " (sensors that take it: " + list +
                             ")");
        }
      }
    }
  }

  void narration() {
    for (const auto& n : s_.timeline) {
      knownOwner(n.origin, n.owner, "timeline entry");
      if (n.when) test(n.origin, *n.when, "timeline entry");
    }
  }

  void test(const Origin& o, const Test& t, const std::string& what) {
    if (t.kind == TestKind::Matches) {
      try {
        std::regex re(t.text);
        (void)re;
      } catch (const std::regex_error& e) {
        fail(o, what + ": matches '" + t.text + "' is not a regular expression: " + e.what());
      }
    }
    if (t.kind == TestKind::Near && !t.nearOwner.empty()) knownOwner(o, t.nearOwner, what);
  }

  void conditions() {
    std::map<std::string, const Condition*> byName;
    for (const auto& c : s_.success) {
      if (byName.count(c.name)) fail(c.origin, "two success conditions are named '" + c.name + "'");
      byName[c.name] = &c;
    }
    for (const auto& c : s_.success) {
      const std::string what = "condition '" + c.name + "'";
      knownOwner(c.origin, c.owner, what);
      test(c.origin, c.test, what);
      if (!c.by && !s_.deadline)
        fail(c.origin, what + " has no deadline: give it by: SECONDS, or the scenario deadline:");
      if (c.after.empty()) continue;
      if (!byName.count(c.after)) {
        fail(c.origin, what + " comes after '" + c.after + "', which is no condition");
        continue;
      }
      // Follow the chain: it must end.
      std::set<std::string> seen{c.name};
      for (const Condition* at = byName[c.after]; at;) {
        if (!seen.insert(at->name).second) {
          fail(c.origin, what + ": its after: chain goes round through '" + at->name + "'");
          break;
        }
        at = at->after.empty() || !byName.count(at->after) ? nullptr : byName[at->after];
      }
    }
    if (s_.success.empty())
      fail(s_.origin, "the scenario has no success conditions: success: [...] says when it passed");
  }

  void launches() {
    RunContext context;
    context.dir = "/tmp/check";
    context.ecology = "check";
    context.speed = s_.speed;
    const auto plan = planLaunches(s_, context, finder_, without_);
    errors.insert(errors.end(), plan.errors.begin(), plan.errors.end());
    for (const auto& g : s_.goals)
      substitute(g.value, s_, context, [&](const std::string& why) { fail(g.origin, why); });
    for (const auto& name : without_) {
      if (!names_.count(name))
        errors.push_back("--without " + name + ": the scenario has no PEIS of that name");
    }
  }

 private:
  const Scenario& s_;
  const ProgramFinder& finder_;
  std::vector<std::string> without_;
  std::set<std::string> names_, ids_;
};

}  // namespace

const std::vector<std::string>& freezablePrograms() {
  static const std::vector<std::string> programs{"peis-sim-sensors"};
  return programs;
}

std::vector<std::string> checkScenario(const Scenario& scenario, const ProgramFinder& finder,
                                       const std::vector<std::string>& without) {
  Checker c(scenario, finder, without);
  c.names();
  c.goals();
  c.faults(scenario.faults);
  c.narration();
  c.conditions();
  c.launches();
  return c.errors;
}

std::vector<std::string> checkFaults(const Scenario& scenario, const std::vector<Fault>& faults,
                                     const ProgramFinder& finder,
                                     const std::vector<std::string>& without) {
  Checker c(scenario, finder, without);
  c.faults(faults);
  return c.errors;
}

}  // namespace peis::scenario
