// Functionality descriptors: what a component can do (typed inputs and
// outputs, preconditions over published facts, activation, cost), read from
// the YAML file shipped with the component and published as tuples so the
// meta-level can plan with them. The schema is in docs/configuration.md (and
// the published tuples in docs/components.md).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace peis {

// A flat term: `image`, `image(cam1)`, `position(?robot)`,
// `activity(?person, kitchen)`. Port types and precondition atoms are terms.
// An argument is a constant (one key part: letters, digits, `-`, `_`, `/`, …)
// or a variable (`?name`). `?self` is reserved: it stands for the name of the
// PEIS that runs the component and is bound before planning.
struct Term {
  std::string functor;
  std::vector<std::string> args;

  // Parses `text`; on failure returns nothing and says why in `problem`.
  static std::optional<Term> parse(std::string_view text, std::string* problem = nullptr);
  // The canonical form: no spaces, `f(a,b)`, `f` when there are no arguments.
  std::string toString() const;
  bool isGround() const;  // no variable argument
  // The variables in order of first appearance ("?r", …).
  std::vector<std::string> variables() const;
  bool operator==(const Term&) const = default;
  auto operator<=>(const Term&) const = default;
};

inline bool isVariable(std::string_view arg) { return !arg.empty() && arg.front() == '?'; }
inline constexpr std::string_view kSelfVariable = "?self";

struct Port {
  std::string name;  // a key part, e.g. "position"
  std::string type;  // a term in canonical form, e.g. "position(?robot)", "image/jpeg"
  // Outputs: the key the output is written to; inputs: the meta tuple the
  // input is read through. May contain the type's variables (`position.?robot`).
  // Empty = the default (see outputKey / inputKey).
  std::string key{};
  bool operator==(const Port&) const = default;

  // The key with variables still in it: the output's own key, defaulting to
  // `<name>` followed by `.<var>` for each variable of the type (not ?self).
  std::string outputKey() const;
  // The meta input key: defaulting to `mi-<name>` followed by `.<var>` for
  // each variable of the type (not ?self).
  std::string inputKey() const;
};

struct Functionality {
  std::string name;
  std::string description;
  std::vector<Port> inputs;
  std::vector<Port> outputs;
  // Atoms over published facts (`in-view(?robot, cam1)`), each a Term in
  // canonical form, or a disequality `?a != ?b` between two variables or a
  // variable and a constant.
  std::vector<std::string> preconditions;
  // The actuator that switches the functionality on and off: the planner's
  // deployment writes `<activation>.reqState` (docs/configuration.md). Empty:
  // the functionality runs whenever the component runs.
  std::string activation;
  double cost = 1.0;
  bool operator==(const Functionality&) const = default;
};

struct Descriptor {
  std::string component;
  std::vector<Functionality> functionalities;

  // Throws Error(InvalidConfig) naming `origin`, the line and the problem.
  static Descriptor fromYaml(std::string_view text, std::string_view origin = "<yaml>");
  static Descriptor fromFile(const std::string& path);
  std::string toYaml() const;
  bool operator==(const Descriptor&) const = default;
};

// A precondition split into its parts: an atom, or `left != right`.
struct Precondition {
  bool disequality = false;
  Term atom;                // when !disequality
  std::string left, right;  // when disequality
  static std::optional<Precondition> parse(std::string_view text, std::string* problem = nullptr);
  std::string toString() const;
};

// "name:type name:type" as published in functionality.<f>.inputs/outputs;
// a port with an explicit key is written `name:type@key`.
std::string formatPorts(const std::vector<Port>& ports);

}  // namespace peis
