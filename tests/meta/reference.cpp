// The naive reference planner, its MILP twin and the validator (reference.h).
#include "reference.h"

#include <glpk.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>

namespace peis::meta::reference {
namespace {

using Values = std::map<std::string, std::string>;

std::string subst(const std::string& text, const Values& v) {
  // Replaces every ?name (letters, digits, '-', '_') in a term or a key.
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    if (text[i] != '?') {
      out += text[i++];
      continue;
    }
    std::size_t end = i + 1;
    while (end < text.size() && (std::isalnum(static_cast<unsigned char>(text[end])) ||
                                 text[end] == '-' || text[end] == '_')) {
      ++end;
    }
    auto it = v.find(text.substr(i, end - i));
    out += it == v.end() ? text.substr(i, end - i) : it->second;
    i = end;
  }
  return out;
}

bool matches(const InstanceSelector& s, const PeisInfo& p, const std::string& component,
             const std::string& functionality, const Values& v) {
  if (!s.peis.empty() && s.peis != p.name && s.peis != std::to_string(p.id)) return false;
  if (!s.component.empty() && s.component != component) return false;
  if (!s.functionality.empty() && s.functionality != functionality) return false;
  for (const auto& [var, value] : s.binding) {
    auto it = v.find(var);
    if (it == v.end() || it->second != value) return false;
  }
  return true;
}

std::string nameOf(const PeisInfo& p, const std::string& c, const std::string& f, const Values& v) {
  std::string name = p.name + "/" + c + "/" + f;
  Values shown = v;
  shown.erase("?self");
  if (!shown.empty()) {
    name += "{";
    bool first = true;
    for (const auto& [var, value] : shown) {
      name += (first ? "" : ",") + var + "=" + value;
      first = false;
    }
    name += "}";
  }
  return name;
}

// Every ground instance of one functionality (facts, disequalities checked).
void instancesOf(const Model& model, int p, const Functionality& f,
                 const std::vector<std::string>& constants, const std::set<std::string>& facts,
                 const std::function<void(const Values&)>& emit) {
  std::set<std::string> vars;
  auto collect = [&](const std::string& text) {
    auto t = Term::parse(text);
    for (const auto& a : t->args) {
      if (isVariable(a) && a != "?self") vars.insert(a);
    }
  };
  for (const auto& port : f.inputs) collect(port.type);
  for (const auto& port : f.outputs) collect(port.type);
  for (const auto& pre : f.preconditions) {
    auto parsed = Precondition::parse(pre);
    if (!parsed->disequality) collect(parsed->atom.toString());
  }
  std::vector<std::string> order(vars.begin(), vars.end());
  Values v{{"?self", model.peis[p].name}};
  std::function<void(std::size_t)> assign = [&](std::size_t k) {
    if (k == order.size()) {
      for (const auto& pre : f.preconditions) {
        auto parsed = Precondition::parse(pre);
        if (parsed->disequality) {
          if (subst(parsed->left, v) == subst(parsed->right, v)) return;
        } else if (!facts.count(subst(parsed->atom.toString(), v))) {
          return;
        }
      }
      emit(v);
      return;
    }
    for (const auto& c : constants) {
      v[order[k]] = c;
      assign(k + 1);
    }
    v.erase(order[k]);
  };
  assign(0);
}

struct Slot {
  int peis;
  std::string key, term;
  bool operator<(const Slot& o) const {
    return std::tie(peis, key, term) < std::tie(o.peis, o.key, o.term);
  }
};

}  // namespace

std::optional<Ground> groundNaively(const Model& model, const Goals& goals,
                                    std::size_t maxInstances) {
  std::set<std::string> constantSet, facts;
  auto constantsOf = [&](const std::string& text) {
    auto t = Term::parse(text);
    if (!t) return;
    for (const auto& a : t->args) {
      if (!isVariable(a)) constantSet.insert(a);
    }
  };
  for (const auto& p : model.peis) {
    constantSet.insert(p.name);
    for (const auto& d : p.components) {
      for (const auto& f : d.functionalities) {
        for (const auto& port : f.inputs) constantsOf(port.type);
        for (const auto& port : f.outputs) constantsOf(port.type);
        for (const auto& pre : f.preconditions) {
          auto parsed = Precondition::parse(pre);
          if (parsed->disequality) {
            if (!isVariable(parsed->left)) constantSet.insert(parsed->left);
            if (!isVariable(parsed->right)) constantSet.insert(parsed->right);
          } else {
            constantsOf(parsed->atom.toString());
          }
        }
      }
    }
  }
  for (const auto& fact : model.facts) {
    facts.insert(fact.atom.toString());
    constantsOf(fact.atom.toString());
  }
  for (const auto& g : goals.information) constantsOf(g.information.toString());
  const std::vector<std::string> constants(constantSet.begin(), constantSet.end());

  Ground ground;
  for (int p = 0; p < static_cast<int>(model.peis.size()); ++p) {
    const auto& peis = model.peis[p];
    if (!peis.alive) continue;
    if (std::count(goals.constraints.avoidPeis.begin(), goals.constraints.avoidPeis.end(),
                   peis.name)) {
      continue;
    }
    for (const auto& d : peis.components) {
      for (const auto& f : d.functionalities) {
        bool tooMany = false;
        instancesOf(model, p, f, constants, facts, [&](const Values& v) {
          for (const auto& s : model.failed) {
            if (matches(s, peis, d.component, f.name, v)) return;
          }
          for (const auto& s : goals.constraints.avoid) {
            if (matches(s, peis, d.component, f.name, v)) return;
          }
          GroundInstance inst;
          inst.name = nameOf(peis, d.component, f.name, v);
          inst.peis = p;
          inst.cost = f.cost;
          for (const auto& s : goals.constraints.prefer) {
            if (matches(s, peis, d.component, f.name, v)) inst.cost = 0;
          }
          for (const auto& port : f.inputs) {
            inst.inputs.push_back(
                {subst(port.inputKey(), v), Term::parse(subst(port.type, v))->toString()});
          }
          for (const auto& port : f.outputs) {
            inst.outputs.push_back(
                {subst(port.outputKey(), v), Term::parse(subst(port.type, v))->toString()});
          }
          ground.instances.push_back(std::move(inst));
          if (ground.instances.size() > maxInstances) tooMany = true;
        });
        if (tooMany) return std::nullopt;
      }
    }
  }
  for (const auto& g : goals.information) {
    Ground::Need need;
    need.term = g.information.toString();
    if (!g.consumerPeis.empty()) {
      need.peis = static_cast<int>(model.findPeis(g.consumerPeis) - model.peis.data());
      need.key = g.consumerKey;
      if (!model.peis[need.peis].alive ||
          std::count(goals.constraints.avoidPeis.begin(), goals.constraints.avoidPeis.end(),
                     g.consumerPeis)) {
        need.term = "unreachable consumer";
      }
    }
    ground.goals.push_back(need);
  }
  return ground;
}

std::optional<double> exhaustiveCost(const Model& model, const Ground& ground) {
  const int n = static_cast<int>(ground.instances.size());
  double best = INFINITY;
  for (std::uint32_t set = 0; set < (1u << n); ++set) {
    double cost = 0;
    for (int i = 0; i < n; ++i) {
      if (set >> i & 1) cost += ground.instances[i].cost;
    }
    if (cost >= best) continue;
    // Two writers of one key on one PEIS.
    std::set<std::pair<int, std::string>> written;
    bool ok = true;
    for (int i = 0; i < n && ok; ++i) {
      if (!(set >> i & 1)) continue;
      std::set<std::string> own;
      for (const auto& [key, term] : ground.instances[i].outputs) own.insert(key);
      for (const auto& key : own) ok = ok && written.insert({ground.instances[i].peis, key}).second;
    }
    if (!ok) continue;
    // The slots needed, each with its users.
    std::map<Slot, std::vector<int>> users;  // -1: a goal
    int goalIndex = 0;
    for (const auto& g : ground.goals) {
      users[{g.peis, g.peis < 0 ? "goal" + std::to_string(goalIndex) : g.key, g.term}].push_back(
          -1);
      ++goalIndex;
    }
    for (int i = 0; i < n; ++i) {
      if (!(set >> i & 1)) continue;
      for (const auto& [key, term] : ground.instances[i].inputs) {
        users[{ground.instances[i].peis, key, term}].push_back(i);
      }
    }
    std::map<std::pair<int, std::string>, std::string> termAt;
    std::vector<std::pair<Slot, std::vector<int>>> slots(users.begin(), users.end());
    std::vector<std::vector<std::pair<int, double>>> options;
    for (const auto& [slot, who] : slots) {
      if (slot.peis >= 0) {
        auto [it, inserted] = termAt.emplace(std::make_pair(slot.peis, slot.key), slot.term);
        if (!inserted && it->second != slot.term) ok = false;
      }
      options.emplace_back();
      for (int p = 0; p < n; ++p) {
        if (!(set >> p & 1)) continue;
        for (const auto& [key, term] : ground.instances[p].outputs) {
          if (term != slot.term) continue;
          const double link = slot.peis < 0 ? 0.0
                                            : model.linkCost(model.peis[ground.instances[p].peis],
                                                             model.peis[slot.peis]);
          options.back().push_back({p, link});
        }
      }
      if (options.back().empty()) ok = false;
    }
    if (!ok) continue;
    std::vector<int> choice(slots.size());
    std::function<void(std::size_t, double)> pick = [&](std::size_t k, double sum) {
      if (sum >= best) return;
      if (k == slots.size()) {
        // Acyclic? Edges user -> producer.
        std::vector<std::vector<int>> next(n);
        for (std::size_t s = 0; s < slots.size(); ++s) {
          for (int u : slots[s].second) {
            if (u >= 0) next[u].push_back(options[s][choice[s]].first);
          }
        }
        std::vector<int> state(n, 0);
        std::function<bool(int)> cyclic = [&](int v) {
          state[v] = 1;
          for (int w : next[v]) {
            if (state[w] == 1 || (state[w] == 0 && cyclic(w))) return true;
          }
          state[v] = 2;
          return false;
        };
        for (int v = 0; v < n; ++v) {
          if (state[v] == 0 && cyclic(v)) return;
        }
        best = sum;
        return;
      }
      for (std::size_t o = 0; o < options[k].size(); ++o) {
        choice[k] = static_cast<int>(o);
        pick(k + 1, sum + options[k][o].second);
      }
    };
    pick(0, cost);
  }
  if (best == INFINITY) return std::nullopt;
  return best;
}

std::optional<double> milpCost(const Model& model, const Ground& ground) {
  const int n = static_cast<int>(ground.instances.size());
  // Slots: (peis, key, term) -> users; goals have user -1.
  std::map<Slot, std::vector<int>> users;
  int goalIndex = 0;
  for (const auto& g : ground.goals) {
    users[{g.peis, g.peis < 0 ? "goal" + std::to_string(goalIndex) : g.key, g.term}].push_back(-1);
    ++goalIndex;
  }
  for (int i = 0; i < n; ++i) {
    for (const auto& [key, term] : ground.instances[i].inputs) {
      users[{ground.instances[i].peis, key, term}].push_back(i);
    }
  }
  glp_prob* lp = glp_create_prob();
  glp_set_obj_dir(lp, GLP_MIN);
  auto column = [&](double cost, int kind, double lo, double hi) {
    const int c = glp_add_cols(lp, 1);
    glp_set_col_kind(lp, c, kind);
    glp_set_col_bnds(lp, c, lo == hi ? GLP_FX : GLP_DB, lo, hi);
    glp_set_obj_coef(lp, c, cost);
    return c;
  };
  auto row = [&](const std::vector<std::pair<int, double>>& terms, int type, double lo, double hi) {
    const int r = glp_add_rows(lp, 1);
    glp_set_row_bnds(lp, r, type, lo, hi);
    std::vector<int> idx{0};
    std::vector<double> val{0};
    for (const auto& [c, v] : terms) {
      idx.push_back(c);
      val.push_back(v);
    }
    glp_set_mat_row(lp, r, static_cast<int>(terms.size()), idx.data(), val.data());
  };
  std::vector<int> x(n), t(n);
  for (int i = 0; i < n; ++i) {
    x[i] = column(ground.instances[i].cost, GLP_BV, 0, 1);
    t[i] = column(0, GLP_CV, 0, n);
  }
  const double big = n + 1;
  std::map<std::pair<int, std::string>, std::vector<int>> requiredAt;  // clash rows
  for (const auto& [slot, who] : users) {
    const bool goal = std::count(who.begin(), who.end(), -1) > 0;
    const int r = column(0, GLP_BV, goal ? 1 : 0, 1);
    if (slot.peis >= 0) requiredAt[{slot.peis, slot.key}].push_back(r);
    for (int u : who) {
      if (u >= 0) row({{r, 1}, {x[u], -1}}, GLP_LO, 0, 0);  // r >= x_u
    }
    std::vector<std::pair<int, double>> pick{{r, -1}};
    for (int p = 0; p < n; ++p) {
      for (const auto& [key, term] : ground.instances[p].outputs) {
        if (term != slot.term) continue;
        const double link = slot.peis < 0 ? 0.0
                                          : model.linkCost(model.peis[ground.instances[p].peis],
                                                           model.peis[slot.peis]);
        const int y = column(link, GLP_BV, 0, 1);
        pick.push_back({y, 1});
        row({{y, 1}, {x[p], -1}}, GLP_UP, 0, 0);  // y <= x_p
        for (int u : who) {
          // u active and fed by p: t_u >= t_p + 1.
          if (u >= 0) row({{t[u], 1}, {t[p], -1}, {y, -big}, {x[u], -big}}, GLP_LO, 1 - 2 * big, 0);
        }
      }
    }
    row(pick, GLP_FX, 0, 0);  // exactly one producer when required
  }
  for (const auto& [where, rs] : requiredAt) {
    // One meta input cannot point at two different terms.
    std::set<std::string> terms;
    (void)terms;
    if (rs.size() < 2) continue;
    for (std::size_t a = 0; a < rs.size(); ++a) {
      for (std::size_t b = a + 1; b < rs.size(); ++b) row({{rs[a], 1}, {rs[b], 1}}, GLP_UP, 0, 1);
    }
  }
  std::map<std::pair<int, std::string>, std::vector<int>> writers;
  for (int i = 0; i < n; ++i) {
    std::set<std::string> own;
    for (const auto& [key, term] : ground.instances[i].outputs) own.insert(key);
    for (const auto& key : own) writers[{ground.instances[i].peis, key}].push_back(i);
  }
  for (const auto& [where, list] : writers) {
    for (std::size_t a = 0; a < list.size(); ++a) {
      for (std::size_t b = a + 1; b < list.size(); ++b) {
        row({{x[list[a]], 1}, {x[list[b]], 1}}, GLP_UP, 0, 1);
      }
    }
  }
  glp_iocp params;
  glp_init_iocp(&params);
  params.presolve = GLP_ON;
  params.msg_lev = GLP_MSG_OFF;
  const int status = glp_intopt(lp, &params);
  std::optional<double> result;
  if (status == 0 && glp_mip_status(lp) == GLP_OPT) result = glp_mip_obj_val(lp);
  glp_delete_prob(lp);
  return result;
}

std::string validate(const Model& model, const Goals& goals, const Configuration& config) {
  struct Active {
    int peis;
    std::vector<std::pair<std::string, std::string>> inputs, outputs;
    double cost;
  };
  std::vector<Active> active;
  std::map<std::pair<int, std::string>, std::pair<int, std::string>>
      producedAt;  // -> (index, term)
  double total = 0;
  for (const auto& a : config.instances) {
    const auto* peis = model.findPeis(a.peis);
    if (!peis) return "unknown PEIS " + a.peis;
    if (!peis->alive) return a.toString() + " runs on a dead PEIS";
    const int p = static_cast<int>(peis - model.peis.data());
    const Functionality* f = nullptr;
    for (const auto& d : peis->components) {
      for (const auto& g : d.functionalities) {
        if (d.component == a.component && g.name == a.functionality) f = &g;
      }
    }
    if (!f) return "no functionality " + a.toString();
    Values v(a.binding.begin(), a.binding.end());
    v["?self"] = peis->name;
    for (const auto& pre : f->preconditions) {
      auto parsed = Precondition::parse(pre);
      if (parsed->disequality) {
        if (subst(parsed->left, v) == subst(parsed->right, v)) return a.toString() + ": " + pre;
        continue;
      }
      const auto atom = subst(parsed->atom.toString(), v);
      bool holds = false;
      for (const auto& fact : model.facts) holds = holds || fact.atom.toString() == atom;
      if (!holds) return a.toString() + ": precondition " + atom + " does not hold";
    }
    for (const auto& s : model.failed) {
      if (matches(s, *peis, a.component, a.functionality, v)) return a.toString() + " has failed";
    }
    for (const auto& s : goals.constraints.avoid) {
      if (matches(s, *peis, a.component, a.functionality, v)) return a.toString() + " is avoided";
    }
    for (const auto& name : goals.constraints.avoidPeis) {
      if (name == peis->name) return a.toString() + " is on an avoided PEIS";
    }
    Active act{p, {}, {}, f->cost};
    for (const auto& s : goals.constraints.prefer) {
      if (matches(s, *peis, a.component, a.functionality, v)) act.cost = 0;
    }
    for (const auto& port : f->inputs) {
      const auto term = Term::parse(subst(port.type, v))->toString();
      if (term.find('?') != std::string::npos) return a.toString() + ": unbound " + term;
      act.inputs.push_back({subst(port.inputKey(), v), term});
    }
    for (const auto& port : f->outputs) {
      const auto term = Term::parse(subst(port.type, v))->toString();
      act.outputs.push_back({subst(port.outputKey(), v), term});
      auto [it, inserted] =
          producedAt.emplace(std::make_pair(p, subst(port.outputKey(), v)),
                             std::make_pair(static_cast<int>(active.size()), term));
      if (!inserted) return "two writers of " + peis->name + "." + it->first.second;
    }
    if (std::abs(act.cost - a.cost) > 1e-9) return a.toString() + ": wrong cost";
    total += act.cost;
    active.push_back(std::move(act));
  }
  // Links: one per (consumer PEIS, key).
  std::map<std::pair<int, std::string>, std::pair<int, std::string>> linkAt;  // -> producer, term
  for (const auto& l : config.links) {
    const auto* c = model.findPeis(l.consumerPeis);
    const auto* p = model.findPeis(l.producerPeis);
    if (!c || !p) return "a link names an unknown PEIS: " + l.toString();
    const int ci = static_cast<int>(c - model.peis.data()),
              pi = static_cast<int>(p - model.peis.data());
    auto it = producedAt.find({pi, l.producerKey});
    if (it == producedAt.end()) return "nothing active writes " + l.toString();
    if (it->second.second != l.information.toString())
      return "wrong information on " + l.toString();
    if (!linkAt.emplace(std::make_pair(ci, l.consumerKey), it->second).second) {
      return "two links into " + l.consumerPeis + "." + l.consumerKey;
    }
    const double cost = model.linkCost(*p, *c);
    if (std::abs(cost - l.cost) > 1e-9) return "wrong link cost on " + l.toString();
    total += cost;
  }
  std::vector<std::vector<int>> next(active.size());
  for (std::size_t i = 0; i < active.size(); ++i) {
    for (const auto& [key, term] : active[i].inputs) {
      auto it = linkAt.find({active[i].peis, key});
      if (it == linkAt.end())
        return config.instances[i].toString() + ": input " + key + " is not linked";
      if (it->second.second != term)
        return config.instances[i].toString() + ": " + key + " gets the wrong information";
      next[i].push_back(it->second.first);
    }
  }
  for (const auto& g : goals.information) {
    const auto term = g.information.toString();
    if (g.consumerPeis.empty()) {
      bool produced = false;
      for (const auto& a : active) {
        for (const auto& [key, t] : a.outputs) produced = produced || t == term;
      }
      if (!produced) return "goal " + g.toString() + " is not produced";
      continue;
    }
    const auto* c = model.findPeis(g.consumerPeis);
    auto it = linkAt.find({static_cast<int>(c - model.peis.data()), g.consumerKey});
    if (it == linkAt.end() || it->second.second != term)
      return "goal " + g.toString() + " is not linked";
  }
  for (const auto& r : goals.run) {
    bool running = false;
    for (const auto& a : config.instances) {
      const auto* peis = model.findPeis(a.peis);
      Values v(a.binding.begin(), a.binding.end());
      running = running || matches(r.instance, *peis, a.component, a.functionality, v);
    }
    if (!running) return "run goal " + r.instance.toString() + " is not running";
  }
  std::vector<int> state(active.size(), 0);
  std::function<bool(int)> cyclic = [&](int v) {
    state[v] = 1;
    for (int w : next[v]) {
      if (state[w] == 1 || (state[w] == 0 && cyclic(w))) return true;
    }
    state[v] = 2;
    return false;
  };
  for (std::size_t v = 0; v < active.size(); ++v) {
    if (state[v] == 0 && cyclic(static_cast<int>(v))) return "the links form a cycle";
  }
  if (std::abs(total - config.cost) > 1e-6) {
    return "the cost " + std::to_string(config.cost) + " is not the sum " + std::to_string(total);
  }
  return "";
}

}  // namespace peis::meta::reference
