// Explanations of unmet goals (see explain.h).
#include "planner/explain.h"

#include <set>

namespace peis::meta::detail {
namespace {

const char* blockText(Block b) {
  switch (b) {
    case Block::DeadPeis:
      return "its PEIS is dead";
    case Block::AvoidedPeis:
      return "its PEIS is avoided";
    case Block::Failed:
      return "it has failed";
    case Block::Avoided:
      return "it is avoided";
    case Block::None:
      break;
  }
  return "";
}

struct Explainer {
  const ModelIndex& index;
  const GroundProblem& problem;
  const std::vector<char>& reachable;
  std::set<std::string> explained;
  std::vector<std::string> lines;

  // Why nobody produces `term`; `indent` nests the causes.
  void term(const std::string& term, const std::string& indent, int depth) {
    if (!explained.insert(term).second) {
      lines.push_back(indent + "no producer of " + term + " (see above)");
      return;
    }
    std::vector<int> candidates;
    for (int i = 0; i < static_cast<int>(problem.instances.size()); ++i) {
      for (const auto& out : problem.instances[i].outputTerms) {
        if (out == term) candidates.push_back(i);
      }
    }
    if (candidates.empty()) {
      lines.push_back(indent + "no producer of " + term + ": " + unmatched(term));
      return;
    }
    lines.push_back(indent + "no producer of " + term + ":");
    for (int i : candidates) instance(i, indent + "  ", depth);
  }

  void instance(int i, const std::string& indent, int depth) {
    const auto& inst = problem.instances[i];
    const auto name = instanceName(index, inst);
    if (inst.block != Block::None) {
      lines.push_back(indent + name + " cannot run: " + blockText(inst.block));
      return;
    }
    if (!reachable[i]) {
      for (int s : inst.slots) {
        const auto& slot = problem.slots[s];
        if (!slot.options.empty()) continue;
        lines.push_back(indent + name + " needs " + slot.term + " (" + slot.key + ")");
        if (depth < 4) term(slot.term, indent + "  ", depth + 1);
        return;
      }
    }
    lines.push_back(indent + name + " could run, but only in a cycle or with a clashing key");
  }

  // No instance produces `term`: which templates came close, and why not.
  std::string unmatched(const std::string& text) {
    auto t = Term::parse(text);
    if (!t) return "not a term";
    auto it = index.producersOf.find(signature(*t));
    if (it == index.producersOf.end()) return "no functionality produces " + t->functor;
    std::string why;
    for (const auto& [templ, out] : it->second) {
      const auto& tp = index.templates[templ];
      const auto& pattern = tp.outputs[out];
      bool constantsDiffer = false;
      for (std::size_t a = 0; a < pattern.args.size(); ++a) {
        if (!isVariable(pattern.args[a]) && pattern.args[a] != t->args[a]) constantsDiffer = true;
      }
      if (constantsDiffer) continue;
      const auto& peis = index.model->peis[tp.peis];
      std::string pre;
      for (const auto& p : tp.preconditions) pre += (pre.empty() ? "" : ", ") + p.toString();
      why += (why.empty() ? "" : "; ") + peis.name + "/" + tp.component->component + "/" +
             tp.functionality->name + " produces " + pattern.toString() +
             (pre.empty() ? " but its inputs cannot be given values"
                          : " but its preconditions (" + pre + ") do not hold for it");
    }
    for (const auto& note : problem.notes) {
      if (note.find(": no value for") != std::string::npos) why += "; " + note;
    }
    return why.empty()
               ? "every functionality producing " + t->functor + " produces it for other arguments"
               : why;
  }
};

}  // namespace

std::vector<std::string> explainGoal(const ModelIndex& index, const GroundProblem& problem,
                                     const std::vector<char>& reachable, int goalSlot) {
  Explainer e{index, problem, reachable, {}, {}};
  const auto& slot = problem.slots[goalSlot];
  if (slot.term.rfind("run ", 0) == 0) {
    bool any = false;
    e.lines.push_back("cannot " + slot.term + ":");
    for (const auto& note : problem.notes) e.lines.push_back("  " + note);
    for (int i = 0; i < static_cast<int>(problem.instances.size()); ++i) {
      // Run candidates are the instances of the selected functionality.
      const auto name = instanceName(index, problem.instances[i]);
      if (slot.term.find(name.substr(0, name.find('{'))) == std::string::npos) continue;
      any = true;
      e.instance(i, "  ", 1);
    }
    if (!any) e.lines.push_back("  its preconditions do not hold for any binding");
    return e.lines;
  }
  for (const auto& note : problem.notes) {
    if (note.find("the consumer") == 0 && note.find(slot.term) != std::string::npos) {
      e.lines.push_back(note);
      return e.lines;
    }
  }
  e.term(slot.term, "", 0);
  return e.lines;
}

}  // namespace peis::meta::detail
