// ConfigurationPlanner: grounding, pruning, decomposition into independent
// parts, a valid configuration for every part first, then branch and bound
// per part until the deadline (docs/configuration.md, "How the planner works").
#include "peis/meta/planner.h"

#include <algorithm>
#include <numeric>
#include <set>

#include "peis/error.h"
#include "planner/explain.h"
#include "planner/grounding.h"
#include "planner/search.h"

namespace peis::meta {

struct ConfigurationPlanner::Index {
  Model model;
  detail::ModelIndex index;
};

ConfigurationPlanner::ConfigurationPlanner(Model model) : index_(std::make_unique<Index>()) {
  index_->model = std::move(model);
  index_->index.build(index_->model);
}
ConfigurationPlanner::~ConfigurationPlanner() = default;
ConfigurationPlanner::ConfigurationPlanner(ConfigurationPlanner&&) noexcept = default;
ConfigurationPlanner& ConfigurationPlanner::operator=(ConfigurationPlanner&&) noexcept = default;

const Model& ConfigurationPlanner::model() const { return index_->model; }

void ConfigurationPlanner::setFailed(const InstanceSelector& selector, bool failed) {
  auto& list = index_->index.failed;
  std::erase(list, selector);
  if (failed) list.push_back(selector);
}

void ConfigurationPlanner::setAlive(std::string_view peis, bool alive) {
  const auto* p = index_->model.findPeis(peis);
  if (!p) throw Error(ErrorCode::InvalidArgument, "unknown PEIS '" + std::string(peis) + "'");
  index_->index.peisAlive[p - index_->model.peis.data()] = alive;
}

namespace {

using Clock = std::chrono::steady_clock;

struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(int n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

ActiveInstance activeInstance(const detail::ModelIndex& index, const detail::Instance& inst) {
  const auto& t = index.templates[inst.templ];
  const auto& peis = index.model->peis[t.peis];
  return {peis.name,
          peis.id,
          t.component->component,
          t.functionality->name,
          inst.binding,
          t.functionality->activation,
          inst.cost};
}

}  // namespace

PlanResult ConfigurationPlanner::plan(const Goals& goals, const PlanOptions& options) const {
  const auto start = Clock::now();
  auto elapsedMs = [&] {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  };
  detail::SearchLimits limits;
  limits.nodeLimit = options.nodeLimit;
  if (options.timeLimit.count() > 0) limits.deadline = start + options.timeLimit;
  if (options.deadline && (!limits.deadline || *options.deadline < *limits.deadline)) {
    limits.deadline = options.deadline;
  }
  const auto& index = index_->index;
  const auto& model = index_->model;

  PlanResult result;
  auto problem = detail::ground(index, goals);
  const auto reachable = detail::pruneUnreachable(problem);
  result.stats.groundInstances = problem.grounded;

  // Goals nobody can serve: explain them all, and stop.
  for (std::size_t g = 0; g < problem.goalSlots.size(); ++g) {
    if (!problem.slots[problem.goalSlots[g]].options.empty()) continue;
    result.status = PlanStatus::Infeasible;
    result.lowerBound = kInfinity;
    for (auto& line : detail::explainGoal(index, problem, reachable, problem.goalSlots[g])) {
      result.explanation.push_back(std::move(line));
    }
  }
  if (result.status == PlanStatus::Infeasible) {
    result.stats.totalMs = elapsedMs();
    return result;
  }
  if (problem.goalSlots.empty()) {
    result.status = PlanStatus::Optimal;
    result.stats.totalMs = elapsedMs();
    return result;
  }

  // The relevant graph from the goals, split into independent parts.
  const int n = static_cast<int>(problem.instances.size());
  const int m = static_cast<int>(problem.slots.size());
  UnionFind uf(n + m);  // instances first, then slots
  std::vector<char> seenSlot(m, 0), seenInst(n, 0);
  std::vector<int> stack(problem.goalSlots.begin(), problem.goalSlots.end());
  for (int s : stack) seenSlot[s] = 1;
  while (!stack.empty()) {
    const int s = stack.back();
    stack.pop_back();
    for (const auto& o : problem.slots[s].options) {
      uf.unite(n + s, o.instance);
      if (seenInst[o.instance]) continue;
      seenInst[o.instance] = 1;
      for (int t : problem.instances[o.instance].slots) {
        uf.unite(o.instance, n + t);
        if (!seenSlot[t]) {
          seenSlot[t] = 1;
          stack.push_back(t);
        }
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    if (!seenInst[i]) continue;
    for (int e : problem.instances[i].exclusive) {
      if (seenInst[e]) uf.unite(i, e);
    }
  }
  for (int s = 0; s < m; ++s) {
    if (!seenSlot[s]) continue;
    for (int c : problem.slots[s].clashes) {
      if (seenSlot[c]) uf.unite(n + s, n + c);
    }
  }
  std::set<std::string> warm;
  if (options.warmStart) {
    for (const auto& a : options.warmStart->instances) warm.insert(a.toString());
  }
  std::vector<int> roots;
  for (int s : problem.goalSlots) {
    const int r = uf.find(n + s);
    if (std::find(roots.begin(), roots.end(), r) == roots.end()) roots.push_back(r);
  }
  std::vector<detail::Part> parts(roots.size());
  std::vector<int> localInst(n, -1), localSlot(m, -1);
  for (std::size_t p = 0; p < roots.size(); ++p) {
    auto& part = parts[p];
    for (int i = 0; i < n; ++i) {
      if (!seenInst[i] || uf.find(i) != roots[p]) continue;
      localInst[i] = static_cast<int>(part.insts.size());
      detail::Part::Inst inst;
      inst.global = i;
      inst.cost = problem.instances[i].cost;
      inst.warm = warm.count(activeInstance(index, problem.instances[i]).toString()) > 0;
      part.insts.push_back(inst);
    }
    for (int s = 0; s < m; ++s) {
      if (!seenSlot[s] || uf.find(n + s) != roots[p]) continue;
      localSlot[s] = static_cast<int>(part.slots.size());
      detail::Part::Slot slot;
      slot.global = s;
      slot.goal = problem.slots[s].goal;
      part.slots.push_back(slot);
    }
    for (auto& inst : part.insts) {
      std::set<int> slots;
      for (int t : problem.instances[inst.global].slots) slots.insert(localSlot[t]);
      inst.slots.assign(slots.begin(), slots.end());
      for (int e : problem.instances[inst.global].exclusive) {
        if (localInst[e] >= 0 && seenInst[e]) inst.exclusive.push_back(localInst[e]);
      }
    }
    for (auto& slot : part.slots) {
      for (const auto& o : problem.slots[slot.global].options) {
        if (slot.warmOption < 0 && part.insts[localInst[o.instance]].warm) {
          slot.warmOption = static_cast<int>(slot.options.size());
        }
        slot.options.push_back({localInst[o.instance], o.link});
      }
      for (int c : problem.slots[slot.global].clashes) {
        if (seenSlot[c]) slot.clashes.push_back(localSlot[c]);
      }
    }
    for (int i = 0; i < static_cast<int>(part.insts.size()); ++i) {
      for (int t : part.insts[i].slots) part.slots[t].users.push_back(i);
    }
    result.stats.relevantInstances += static_cast<std::int64_t>(part.insts.size());
  }
  result.stats.parts = static_cast<std::int64_t>(parts.size());
  // A valid configuration for every part first, then the optimum.
  std::vector<detail::PartSearch> searches;
  searches.reserve(parts.size());
  std::vector<detail::PartSolution> solutions;
  for (auto& part : parts) {
    searches.emplace_back(part);
    // The node limit is for the improvement; the deadline holds throughout.
    detail::SearchLimits firstLimits;
    firstLimits.deadline = limits.deadline;
    solutions.push_back(searches.back().first(firstLimits));
    result.stats.nodes += solutions.back().nodes;
  }
  result.stats.firstSolutionMs = elapsedMs();
  if (!options.firstSolutionOnly) {
    for (std::size_t p = 0; p < parts.size(); ++p) {
      solutions[p].nodes = 0;
      solutions[p] = searches[p].polish(std::move(solutions[p]), limits);
      solutions[p] = searches[p].improve(std::move(solutions[p]), limits);
      result.stats.nodes += solutions[p].nodes;
    }
  }

  bool allFound = true, allOptimal = !options.firstSolutionOnly, infeasible = false;
  double lower = 0;
  for (std::size_t p = 0; p < parts.size(); ++p) {
    const auto& sol = solutions[p];
    allFound = allFound && sol.found;
    allOptimal = allOptimal && sol.optimal;
    if (!sol.found && sol.optimal) infeasible = true;
    lower += sol.lowerBound;
  }
  if (infeasible) {
    result.status = PlanStatus::Infeasible;
    result.lowerBound = kInfinity;
    for (std::size_t p = 0; p < parts.size(); ++p) {
      if (solutions[p].found) continue;
      std::string goalsOfPart;
      for (std::size_t g = 0; g < problem.goalSlots.size(); ++g) {
        if (localSlot[problem.goalSlots[g]] >= 0 && uf.find(n + problem.goalSlots[g]) == roots[p]) {
          goalsOfPart += (goalsOfPart.empty() ? "" : ", ") + problem.goalNames[g];
        }
      }
      result.explanation.push_back(
          "no configuration meets " + goalsOfPart +
          " together: every way needs a cycle of producers, two writers of one key, or two "
          "producers for one meta input");
    }
    result.stats.totalMs = elapsedMs();
    return result;
  }
  if (!allFound) {
    result.status = PlanStatus::Unknown;
    result.lowerBound = lower;
    result.stats.totalMs = elapsedMs();
    return result;
  }
  result.status = allOptimal ? PlanStatus::Optimal : PlanStatus::Feasible;
  auto& config = result.configuration;
  for (std::size_t p = 0; p < parts.size(); ++p) {
    const auto& part = parts[p];
    const auto& sol = solutions[p];
    config.cost += sol.cost;
    for (int i = 0; i < static_cast<int>(part.insts.size()); ++i) {
      if (sol.active[i]) {
        config.instances.push_back(activeInstance(index, problem.instances[part.insts[i].global]));
      }
    }
    for (int s = 0; s < static_cast<int>(part.slots.size()); ++s) {
      if (sol.chosen[s] < 0) continue;
      const auto& slot = problem.slots[part.slots[s].global];
      if (slot.consumerPeis < 0) continue;
      const auto& option = slot.options[sol.chosen[s]];
      const auto& producer = problem.instances[option.instance];
      const auto& producerPeis = model.peis[index.templates[producer.templ].peis];
      const auto& consumerPeis = model.peis[slot.consumerPeis];
      Link link;
      link.consumerPeis = consumerPeis.name;
      link.consumerId = consumerPeis.id;
      link.consumerKey = slot.key;
      link.producerPeis = producerPeis.name;
      link.producerId = producerPeis.id;
      link.producerKey = producer.outputKeys[option.output];
      link.information = *Term::parse(slot.term);
      link.kind = model.linkKind(producerPeis, consumerPeis);
      link.cost = option.link;
      config.links.push_back(std::move(link));
    }
  }
  std::sort(config.instances.begin(), config.instances.end());
  std::sort(config.links.begin(), config.links.end());
  result.lowerBound = allOptimal ? config.cost : std::min(lower, config.cost);
  result.stats.totalMs = elapsedMs();
  return result;
}

const char* toString(PlanStatus status) {
  switch (status) {
    case PlanStatus::Optimal:
      return "optimal";
    case PlanStatus::Feasible:
      return "feasible";
    case PlanStatus::Infeasible:
      return "infeasible";
    case PlanStatus::Unknown:
      return "unknown";
  }
  return "unknown";
}

double PlanResult::gap() const {
  if (!ok() || configuration.cost <= 0) return 0;
  return std::max(0.0, (configuration.cost - lowerBound) / configuration.cost);
}

}  // namespace peis::meta
