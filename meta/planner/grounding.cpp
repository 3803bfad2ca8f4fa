// Grounding of functionality templates against goals, facts and producible
// information (see grounding.h).
#include "planner/grounding.h"

#include <algorithm>
#include <deque>
#include <functional>
#include <set>
#include <unordered_set>

#include "peis/error.h"

namespace peis::meta::detail {
namespace {

using Table = std::unordered_map<std::string, std::vector<std::vector<std::string>>>;
using Map = std::map<std::string, std::string>;

Term substitute(const Term& t, const Map& b) {
  Term out{t.functor, {}};
  out.args.reserve(t.args.size());
  for (const auto& a : t.args) {
    auto it = isVariable(a) ? b.find(a) : b.end();
    out.args.push_back(it == b.end() ? a : it->second);
  }
  return out;
}

std::string substituteKey(const std::string& key, const Map& b) {
  std::string out;
  std::size_t i = 0;
  while (i < key.size()) {
    if (key[i] == '?') {
      auto end = i + 1;
      while (end < key.size() && key[end] != '.') ++end;
      const auto var = key.substr(i, end - i);
      auto it = b.find(var);
      out += it == b.end() ? var : it->second;
      i = end;
    } else {
      out += key[i++];
    }
  }
  return out;
}

std::string selfKey(const std::string& key, const std::string& self) {
  return substituteKey(key, Map{{std::string(kSelfVariable), self}});
}

// Extends `b` so that `pattern` equals `ground`; false when it cannot.
bool unify(const Term& pattern, const std::vector<std::string>& groundArgs, Map& b,
           std::vector<std::string>& added) {
  for (std::size_t i = 0; i < pattern.args.size(); ++i) {
    const auto& a = pattern.args[i];
    if (!isVariable(a)) {
      if (a != groundArgs[i]) return false;
      continue;
    }
    auto it = b.find(a);
    if (it == b.end()) {
      b.emplace(a, groundArgs[i]);
      added.push_back(a);
    } else if (it->second != groundArgs[i]) {
      return false;
    }
  }
  return true;
}

struct Atom {
  const Term* term;
  const Table* table;
  const std::unordered_map<std::string, bool>* set;
  bool required;  // false: only matched when it still has an unbound variable
};

bool hasUnbound(const Term& t, const Map& b) {
  for (const auto& a : t.args) {
    if (isVariable(a) && !b.count(a)) return true;
  }
  return false;
}

// Backtracking join: every complete extension of `b` satisfying the atoms.
void join(const std::vector<Atom>& atoms, std::size_t i, Map& b,
          const std::function<void(Map&)>& emit) {
  if (i == atoms.size()) {
    emit(b);
    return;
  }
  const auto& atom = atoms[i];
  if (!hasUnbound(*atom.term, b)) {
    if (!atom.required || atom.set->count(substitute(*atom.term, b).toString())) {
      join(atoms, i + 1, b, emit);
    }
    return;
  }
  auto it = atom.table->find(signature(*atom.term));
  if (it == atom.table->end()) return;
  std::vector<std::string> added;
  for (const auto& args : it->second) {
    added.clear();
    if (unify(*atom.term, args, b, added)) join(atoms, i + 1, b, emit);
    for (const auto& v : added) b.erase(v);
  }
}

bool disequalitiesHold(const std::vector<Precondition>& pre, const Map& b) {
  for (const auto& p : pre) {
    if (!p.disequality) continue;
    auto value = [&](const std::string& side) {
      auto it = isVariable(side) ? b.find(side) : b.end();
      return it == b.end() ? side : it->second;
    };
    if (value(p.left) == value(p.right)) return false;
  }
  return true;
}

Binding toBinding(const Map& m) { return Binding(m.begin(), m.end()); }

}  // namespace

std::string signature(const Term& t) { return t.functor + "/" + std::to_string(t.args.size()); }

void ModelIndex::build(const Model& m) {
  model = &m;
  templates.clear();
  producersOf.clear();
  facts.clear();
  producible.clear();
  factSet.clear();
  producibleSet.clear();
  peisAlive.clear();
  failed = m.failed;
  for (int p = 0; p < static_cast<int>(m.peis.size()); ++p) {
    const auto& peis = m.peis[p];
    peisAlive.push_back(peis.alive);
    const Map self{{std::string(kSelfVariable), peis.name}};
    for (const auto& d : peis.components) {
      for (const auto& f : d.functionalities) {
        Template t;
        t.peis = p;
        t.component = &d;
        t.functionality = &f;
        std::set<std::string> vars;
        auto add = [&](const Term& term) {
          for (const auto& v : term.variables()) vars.insert(v);
        };
        for (const auto& port : f.inputs) {
          t.inputs.push_back(substitute(*Term::parse(port.type), self));
          t.inputKeys.push_back(selfKey(port.inputKey(), peis.name));
          add(t.inputs.back());
        }
        for (const auto& port : f.outputs) {
          t.outputs.push_back(substitute(*Term::parse(port.type), self));
          t.outputKeys.push_back(selfKey(port.outputKey(), peis.name));
          add(t.outputs.back());
        }
        for (const auto& text : f.preconditions) {
          auto pre = Precondition::parse(text);
          if (!pre) continue;  // the descriptor parser checked it
          if (pre->disequality) {
            if (pre->left == kSelfVariable) pre->left = peis.name;
            if (pre->right == kSelfVariable) pre->right = peis.name;
          } else {
            pre->atom = substitute(pre->atom, self);
            add(pre->atom);
          }
          t.preconditions.push_back(*pre);
        }
        t.variables.assign(vars.begin(), vars.end());
        const int id = static_cast<int>(templates.size());
        for (int o = 0; o < static_cast<int>(t.outputs.size()); ++o) {
          producersOf[signature(t.outputs[o])].push_back({id, o});
        }
        templates.push_back(std::move(t));
      }
    }
  }
  for (const auto& fact : m.facts) {
    if (factSet.emplace(fact.atom.toString(), true).second) {
      facts[signature(fact.atom)].push_back(fact.atom.args);
    }
  }
  // What can be produced at all (facts hold, inputs producible), ignoring
  // liveness: only used to give values to input variables.
  bool changed = true;
  while (changed) {
    changed = false;
    for (const auto& t : templates) {
      std::vector<Atom> atoms;
      for (const auto& p : t.preconditions) {
        if (!p.disequality) atoms.push_back({&p.atom, &facts, &factSet, true});
      }
      for (const auto& in : t.inputs) atoms.push_back({&in, &producible, &producibleSet, true});
      Map b;
      std::vector<Term> found;
      join(atoms, 0, b, [&](Map& full) {
        if (!disequalitiesHold(t.preconditions, full)) return;
        for (const auto& out : t.outputs) {
          if (!hasUnbound(out, full)) found.push_back(substitute(out, full));
        }
      });
      for (const auto& term : found) {
        if (producibleSet.emplace(term.toString(), true).second) {
          producible[signature(term)].push_back(term.args);
          changed = true;
        }
      }
    }
  }
}

bool selects(const ModelIndex& index, const InstanceSelector& s, const Template& t,
             const Binding& binding) {
  const auto& peis = index.model->peis[t.peis];
  if (!s.peis.empty() && s.peis != peis.name && s.peis != std::to_string(peis.id)) return false;
  if (!s.component.empty() && s.component != t.component->component) return false;
  if (!s.functionality.empty() && s.functionality != t.functionality->name) return false;
  for (const auto& [var, value] : s.binding) {
    bool ok = false;
    for (const auto& [v, x] : binding) ok = ok || (v == var && x == value);
    if (!ok) return false;
  }
  return true;
}

std::string instanceName(const ModelIndex& index, const Instance& instance) {
  const auto& t = index.templates[instance.templ];
  std::string text =
      index.model->peis[t.peis].name + "/" + t.component->component + "/" + t.functionality->name;
  if (!instance.binding.empty()) {
    text += "{";
    for (std::size_t i = 0; i < instance.binding.size(); ++i) {
      text += (i ? "," : "") + instance.binding[i].first + "=" + instance.binding[i].second;
    }
    text += "}";
  }
  return text;
}

GroundProblem ground(const ModelIndex& index, const Goals& goals) {
  const auto& model = *index.model;
  GroundProblem problem;
  std::set<int> avoidedPeis;
  for (const auto& name : goals.constraints.avoidPeis) {
    const auto* p = model.findPeis(name);
    if (!p) {
      const auto at = goals.constraints.avoidPeisOrigin.find(name);
      const auto where =
          at == goals.constraints.avoidPeisOrigin.end() ? std::string() : " (" + at->second + ")";
      throw Error(ErrorCode::InvalidArgument, "avoid: unknown PEIS '" + name + "'" + where);
    }
    avoidedPeis.insert(static_cast<int>(p - model.peis.data()));
  }
  std::unordered_map<std::string, int> instanceIds;
  std::deque<int> fresh;
  auto blockOf = [&](const Template& t, const Binding& b) {
    if (!index.peisAlive[t.peis]) return Block::DeadPeis;
    if (avoidedPeis.count(t.peis)) return Block::AvoidedPeis;
    for (const auto& s : index.failed) {
      if (selects(index, s, t, b)) return Block::Failed;
    }
    for (const auto& s : goals.constraints.avoid) {
      if (selects(index, s, t, b)) return Block::Avoided;
    }
    return Block::None;
  };
  auto instanceFor = [&](int templ, const Map& full) {
    const auto& t = index.templates[templ];
    if (full.size() != t.variables.size()) {
      for (const auto& v : t.variables) {
        if (!full.count(v)) {
          problem.notes.push_back(model.peis[t.peis].name + "/" + t.component->component + "/" +
                                  t.functionality->name + ": no value for " + v);
          break;
        }
      }
      return -1;
    }
    auto binding = toBinding(full);
    std::string id = std::to_string(templ);
    for (const auto& [v, x] : binding) id += "|" + x;
    auto [it, inserted] = instanceIds.emplace(id, static_cast<int>(problem.instances.size()));
    if (!inserted) return it->second;
    Instance inst;
    inst.templ = templ;
    inst.binding = std::move(binding);
    inst.cost = t.functionality->cost;
    inst.block = blockOf(t, inst.binding);
    for (const auto& s : goals.constraints.prefer) {
      if (selects(index, s, t, inst.binding)) inst.cost = 0;
    }
    for (std::size_t o = 0; o < t.outputs.size(); ++o) {
      inst.outputTerms.push_back(substitute(t.outputs[o], full).toString());
      inst.outputKeys.push_back(substituteKey(t.outputKeys[o], full));
    }
    problem.instances.push_back(std::move(inst));
    ++problem.grounded;
    fresh.push_back(it->second);
    return it->second;
  };
  // Completes `b` with facts, then producible information for variables still open.
  auto complete = [&](int templ, Map& b, const std::function<void(Map&)>& emit) {
    const auto& t = index.templates[templ];
    std::vector<Atom> atoms;
    for (const auto& p : t.preconditions) {
      if (!p.disequality) atoms.push_back({&p.atom, &index.facts, &index.factSet, true});
    }
    for (const auto& in : t.inputs) {
      atoms.push_back({&in, &index.producible, &index.producibleSet, false});
    }
    for (const auto& out : t.outputs) {
      atoms.push_back({&out, &index.producible, &index.producibleSet, false});
    }
    join(atoms, 0, b, [&](Map& full) {
      if (disequalitiesHold(t.preconditions, full)) emit(full);
    });
  };

  std::unordered_set<std::string> demanded;
  std::deque<Term> demand;
  auto want = [&](const Term& term) {
    if (demanded.insert(term.toString()).second) demand.push_back(term);
  };
  for (const auto& g : goals.information) {
    const auto where = g.origin.empty() ? std::string() : " (" + g.origin + ")";
    if (!index.producersOf.count(signature(g.information))) {
      throw Error(ErrorCode::InvalidArgument,
                  "goal " + g.toString() + where + ": no functionality in the model produces '" +
                      g.information.functor + "' with " +
                      std::to_string(g.information.args.size()) + " argument(s)");
    }
    if (!g.consumerPeis.empty() && !model.findPeis(g.consumerPeis)) {
      throw Error(ErrorCode::InvalidArgument,
                  "goal " + g.toString() + where + ": unknown PEIS '" + g.consumerPeis + "'");
    }
    want(g.information);
  }
  std::vector<std::vector<int>> runCandidates;
  for (const auto& r : goals.run) {
    runCandidates.emplace_back();
    bool any = false;
    for (int ti = 0; ti < static_cast<int>(index.templates.size()); ++ti) {
      const auto& t = index.templates[ti];
      if (!selects(
              index,
              InstanceSelector{r.instance.peis, r.instance.component, r.instance.functionality, {}},
              t, {})) {
        continue;
      }
      any = true;
      Map b(r.instance.binding.begin(), r.instance.binding.end());
      complete(ti, b, [&](Map& full) {
        const int id = instanceFor(ti, full);
        if (id >= 0) runCandidates.back().push_back(id);
      });
    }
    if (!any) {
      throw Error(ErrorCode::InvalidArgument, "run " + r.instance.toString() +
                                                  (r.origin.empty() ? "" : " (" + r.origin + ")") +
                                                  ": no such functionality in the model");
    }
  }
  // Backwards from the demanded information: producers, then their inputs.
  while (!demand.empty() || !fresh.empty()) {
    while (!fresh.empty()) {
      const int id = fresh.front();
      fresh.pop_front();
      if (problem.instances[id].block != Block::None) continue;
      const auto& t = index.templates[problem.instances[id].templ];
      const Map b(problem.instances[id].binding.begin(), problem.instances[id].binding.end());
      for (const auto& in : t.inputs) want(substitute(in, b));
    }
    if (demand.empty()) break;
    const Term term = demand.front();
    demand.pop_front();
    auto it = index.producersOf.find(signature(term));
    if (it == index.producersOf.end()) continue;
    for (const auto& [templ, out] : it->second) {
      Map b;
      std::vector<std::string> added;
      if (!unify(index.templates[templ].outputs[out], term.args, b, added)) continue;
      complete(templ, b, [&](Map& full) { instanceFor(templ, full); });
    }
  }

  // Slots: one per (consumer PEIS, meta key, information).
  std::unordered_map<std::string, int> slotIds;
  std::unordered_map<std::string, std::vector<std::pair<int, int>>> producersByTerm;
  for (int i = 0; i < static_cast<int>(problem.instances.size()); ++i) {
    const auto& inst = problem.instances[i];
    if (inst.block != Block::None) continue;
    for (int o = 0; o < static_cast<int>(inst.outputTerms.size()); ++o) {
      producersByTerm[inst.outputTerms[o]].push_back({i, o});
    }
  }
  auto slotFor = [&](int peis, const std::string& key, const std::string& term,
                     const std::string& identity) {
    auto [it, inserted] = slotIds.emplace(identity, static_cast<int>(problem.slots.size()));
    if (inserted) {
      Slot s;
      s.consumerPeis = peis;
      s.key = key;
      s.term = term;
      auto p = producersByTerm.find(term);
      if (p != producersByTerm.end()) {
        for (const auto& [inst, out] : p->second) {
          const auto& producer = model.peis[index.templates[problem.instances[inst].templ].peis];
          const double link = peis < 0 ? 0.0 : model.linkCost(producer, model.peis[peis]);
          s.options.push_back({inst, out, link});
        }
      }
      problem.slots.push_back(std::move(s));
    }
    return it->second;
  };
  for (int i = 0; i < static_cast<int>(problem.instances.size()); ++i) {
    if (problem.instances[i].block != Block::None) continue;
    const int templ = problem.instances[i].templ;
    const auto& t = index.templates[templ];
    const Map b(problem.instances[i].binding.begin(), problem.instances[i].binding.end());
    for (std::size_t k = 0; k < t.inputs.size(); ++k) {
      const auto term = substitute(t.inputs[k], b).toString();
      const auto key = substituteKey(t.inputKeys[k], b);
      const int s = slotFor(t.peis, key, term, std::to_string(t.peis) + "|" + key + "|" + term);
      problem.instances[i].slots.push_back(s);
    }
  }
  for (std::size_t g = 0; g < goals.information.size(); ++g) {
    const auto& goal = goals.information[g];
    const auto term = goal.information.toString();
    int s;
    if (goal.consumerPeis.empty()) {
      s = slotFor(-1, "", term, "goal#" + std::to_string(g));
    } else {
      const int peis = static_cast<int>(model.findPeis(goal.consumerPeis) - model.peis.data());
      s = slotFor(peis, goal.consumerKey, term,
                  std::to_string(peis) + "|" + goal.consumerKey + "|" + term);
      if (!index.peisAlive[peis] || avoidedPeis.count(peis)) {
        problem.notes.push_back("the consumer " + goal.consumerPeis + " of " + goal.toString() +
                                (index.peisAlive[peis] ? " is avoided" : " is dead"));
        problem.slots[s].options.clear();
      }
    }
    problem.slots[s].goal = true;
    problem.goalSlots.push_back(s);
    problem.goalNames.push_back(goal.toString());
  }
  for (std::size_t r = 0; r < goals.run.size(); ++r) {
    Slot s;
    s.term = "run " + goals.run[r].instance.toString();
    s.goal = true;
    for (int id : runCandidates[r]) {
      if (problem.instances[id].block == Block::None) s.options.push_back({id, -1, 0});
    }
    problem.goalSlots.push_back(static_cast<int>(problem.slots.size()));
    problem.goalNames.push_back(s.term);
    problem.slots.push_back(std::move(s));
  }
  // Two terms for one meta input of one PEIS, two writers of one key.
  std::unordered_map<std::string, std::vector<int>> byKey;
  for (int s = 0; s < static_cast<int>(problem.slots.size()); ++s) {
    if (problem.slots[s].consumerPeis >= 0) {
      byKey[std::to_string(problem.slots[s].consumerPeis) + "|" + problem.slots[s].key].push_back(
          s);
    }
  }
  for (const auto& [key, list] : byKey) {
    for (int a : list) {
      for (int b : list) {
        if (a != b) problem.slots[a].clashes.push_back(b);
      }
    }
  }
  std::unordered_map<std::string, std::vector<int>> writers;
  for (int i = 0; i < static_cast<int>(problem.instances.size()); ++i) {
    const auto& inst = problem.instances[i];
    if (inst.block != Block::None) continue;
    std::set<std::string> keys(inst.outputKeys.begin(), inst.outputKeys.end());
    for (const auto& k : keys) {
      writers[std::to_string(index.templates[inst.templ].peis) + "|" + k].push_back(i);
    }
  }
  for (const auto& [key, list] : writers) {
    for (int a : list) {
      for (int b : list) {
        if (a != b) problem.instances[a].exclusive.push_back(b);
      }
    }
  }
  for (auto& inst : problem.instances) {
    std::sort(inst.exclusive.begin(), inst.exclusive.end());
    inst.exclusive.erase(std::unique(inst.exclusive.begin(), inst.exclusive.end()),
                         inst.exclusive.end());
  }
  return problem;
}

std::vector<char> pruneUnreachable(GroundProblem& problem) {
  const int n = static_cast<int>(problem.instances.size());
  std::vector<char> reachable(n, 0), slotReached(problem.slots.size(), 0);
  std::vector<int> missing(n, 0);
  std::vector<std::vector<int>> users(problem.slots.size());
  std::deque<int> queue;
  for (int i = 0; i < n; ++i) {
    const auto& inst = problem.instances[i];
    if (inst.block != Block::None) continue;
    std::set<int> distinct(inst.slots.begin(), inst.slots.end());
    missing[i] = static_cast<int>(distinct.size());
    for (int s : distinct) users[s].push_back(i);
    if (missing[i] == 0) {
      reachable[i] = 1;
      queue.push_back(i);
    }
  }
  // producers -> slots they can fill
  std::vector<std::vector<int>> fills(n);
  for (int s = 0; s < static_cast<int>(problem.slots.size()); ++s) {
    for (const auto& o : problem.slots[s].options) fills[o.instance].push_back(s);
  }
  while (!queue.empty()) {
    const int i = queue.front();
    queue.pop_front();
    for (int s : fills[i]) {
      if (slotReached[s]) continue;
      slotReached[s] = 1;
      for (int u : users[s]) {
        if (--missing[u] == 0) {
          reachable[u] = 1;
          queue.push_back(u);
        }
      }
    }
  }
  for (auto& slot : problem.slots) {
    std::erase_if(slot.options, [&](const Option& o) { return !reachable[o.instance]; });
  }
  return reachable;
}

}  // namespace peis::meta::detail
