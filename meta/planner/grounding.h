// Grounding: from the model's functionality templates and the goals to the
// ground problem the search works on. Functionality instances are created
// backwards from the goals (only what can serve a goal), their variables bound
// by the demanded information, the published facts and the information the
// model can produce at all; then instances that can never get their inputs
// are dropped. Internal to the planner.
#pragma once

#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "peis/meta/goals.h"
#include "peis/meta/model.h"

namespace peis::meta::detail {

using Binding = std::vector<std::pair<std::string, std::string>>;  // sorted by variable

// One functionality of one component on one PEIS, ?self replaced.
struct Template {
  int peis = 0;  // index into Model::peis
  const Descriptor* component = nullptr;
  const Functionality* functionality = nullptr;
  std::vector<Term> inputs, outputs;
  std::vector<std::string> inputKeys, outputKeys;  // with variables
  std::vector<Precondition> preconditions;
  std::vector<std::string> variables;  // all of them, sorted
};

// The model, indexed once per planner.
struct ModelIndex {
  const Model* model = nullptr;
  std::vector<Template> templates;
  // "functor/arity" -> (template, output index)
  std::unordered_map<std::string, std::vector<std::pair<int, int>>> producersOf;
  // "functor/arity" -> ground argument lists; facts, and what can be produced at all.
  std::unordered_map<std::string, std::vector<std::vector<std::string>>> facts, producible;
  std::unordered_map<std::string, bool> factSet, producibleSet;  // canonical text
  std::vector<char> peisAlive;           // by PEIS index (setAlive changes it)
  std::vector<InstanceSelector> failed;  // Model::failed plus setFailed

  void build(const Model& m);
};

std::string signature(const Term& t);  // "functor/arity"

// Why an instance is not planned with.
enum class Block { None, DeadPeis, AvoidedPeis, Failed, Avoided };

struct Instance {
  int templ = 0;
  Binding binding;
  double cost = 0;  // as counted (0 when preferred)
  Block block = Block::None;
  std::vector<int> slots;                // the inputs' slots (by input order)
  std::vector<std::string> outputKeys;   // ground
  std::vector<std::string> outputTerms;  // canonical
  std::vector<int> exclusive;            // instances writing one of the same keys
};

struct Option {
  int instance = 0;
  int output = -1;  // -1: a run goal (the instance itself)
  double link = 0;
};

// A meta input of one PEIS that must point at producers of one term (or a
// goal's pseudo-input).
struct Slot {
  int consumerPeis = -1;  // -1: no consumer (a goal without one, or a run goal)
  std::string key;
  std::string term;
  std::vector<Option> options;
  std::vector<int> clashes;  // slots with the same PEIS and key but another term
  bool goal = false;
};

struct GroundProblem {
  std::vector<Instance> instances;
  std::vector<Slot> slots;
  std::vector<int> goalSlots;  // in goal order (information goals, then run goals)
  std::vector<std::string> goalNames;
  // Instances that could not be made (a variable without a value) and other
  // findings, for explanations.
  std::vector<std::string> notes;
  std::int64_t grounded = 0;
};

// Throws Error(InvalidArgument) for a goal naming an unknown PEIS or type.
GroundProblem ground(const ModelIndex& index, const Goals& goals);

// Drops instances that can never get all their inputs (and the options
// naming them); returns the reachable flag per instance.
std::vector<char> pruneUnreachable(GroundProblem& problem);

std::string instanceName(const ModelIndex& index, const Instance& instance);
bool selects(const ModelIndex& index, const InstanceSelector& s, const Template& t,
             const Binding& binding);

}  // namespace peis::meta::detail
