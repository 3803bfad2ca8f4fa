// What the configuration planner is asked for: information that must be
// produced (and, usually, delivered to a consumer's meta input), functionality
// instances that must run, and constraints (avoid, prefer). Read from a goal
// file, the command line, or built in code (docs/configuration.md, "Goals").
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/descriptor.h"
#include "peis/meta/model.h"

namespace peis::meta {

// `position(pippi)` delivered to `pippi.mi-position`: the configuration points
// the consumer's meta tuple at a producer's output. Without a consumer, the
// information must only be produced by some active functionality.
struct InformationGoal {
  Term information;              // ground
  std::string consumerPeis;      // PEIS name or id; empty: no consumer
  std::string consumerKey;       // the meta input key, e.g. "mi-position"
  std::string origin;            // where it was declared ("goals.yaml:3", "argument 2"), for errors
  std::string toString() const;  // `position(pippi)@pippi.mi-position`
  bool operator==(const InformationGoal&) const = default;
};

// A functionality that must run, with its inputs supplied (the selector must
// name one PEIS, component and functionality; a partial binding is allowed).
struct RunGoal {
  InstanceSelector instance;
  std::string origin;
  bool operator==(const RunGoal&) const = default;
};

struct Constraints {
  std::vector<std::string> avoidPeis;  // never plan on these PEIS
  // Where each of avoidPeis was declared ("goals.yaml:4", "argument 3"), for errors.
  std::map<std::string, std::string> avoidPeisOrigin;
  std::vector<InstanceSelector> avoid;   // never activate these instances
  std::vector<InstanceSelector> prefer;  // their own cost is waived when chosen
  bool operator==(const Constraints&) const = default;
};

struct Goals {
  std::vector<InformationGoal> information;
  std::vector<RunGoal> run;
  Constraints constraints;

  bool empty() const { return information.empty() && run.empty(); }
  // Reads a goal file; throws Error(InvalidConfig) "<origin>:<line>: <problem>".
  static Goals fromYaml(std::string_view text, std::string_view origin = "<goals>");
  static Goals fromFile(const std::string& path);
  // One goal per argument: `TERM`, `TERM@PEIS.KEY`, `run:SELECTOR`,
  // `avoid:PEIS`, `avoid:SELECTOR`, `prefer:SELECTOR` (SELECTOR is
  // `peis/component/functionality{?var=value,…}`). Throws
  // Error(InvalidArgument) naming the argument and the problem.
  static Goals fromArguments(const std::vector<std::string>& arguments);
  std::string toYaml() const;
  bool operator==(const Goals&) const = default;
};

}  // namespace peis::meta
