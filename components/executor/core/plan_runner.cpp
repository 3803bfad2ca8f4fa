// The plan executor's state machine (see plan_runner.h).
#include "plan_runner.h"

#include <algorithm>
#include <stdexcept>

namespace peis::executor {

std::string PlanStep::toString() const { return exec::Action{action, args}.toString(); }

const char* toString(Phase phase) {
  switch (phase) {
    case Phase::Idle:
      return "idle";
    case Phase::Deploying:
      return "deploying";
    case Phase::Dispatching:
      return "dispatching";
    case Phase::Executing:
      return "executing";
    case Phase::Replanning:
      return "replanning";
    case Phase::Succeeded:
      return "succeeded";
    case Phase::Failed:
      return "failed";
  }
  return "idle";
}

void ActionMap::add(const std::string& rule) {
  const auto eq = rule.find('=');
  const auto colon = rule.find(':', eq == std::string::npos ? 0 : eq);
  if (eq == std::string::npos || colon == std::string::npos || eq == 0 || colon == eq + 1 ||
      colon + 1 == rule.size())
    throw std::invalid_argument("action rule '" + rule +
                                "': expected NAME=PEIS:GOAL, e.g. GoTo=$1:GoTo($2)");
  const std::string peis = rule.substr(eq + 1, colon - eq - 1), goal = rule.substr(colon + 1);
  if (peis == "set" && (goal.find('=') == std::string::npos || goal.front() == '='))
    throw std::invalid_argument("action rule '" + rule +
                                "': expected NAME=set:KEY=VALUE, e.g. TurnOn=set:LightValue=100");
  rules_[rule.substr(0, eq)] = {peis, goal};
}

namespace {

// Replaces $1..$9 by the step's arguments; false if one is missing.
bool substitute(const std::string& pattern, const std::vector<std::string>& args, std::string& out,
                std::string& why) {
  out.clear();
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] == '$' && i + 1 < pattern.size() && pattern[i + 1] >= '1' &&
        pattern[i + 1] <= '9') {
      const std::size_t n = static_cast<std::size_t>(pattern[i + 1] - '1');
      if (n >= args.size()) {
        why = "'" + pattern + "' uses $" + std::to_string(n + 1) + " but the step has " +
              std::to_string(args.size()) + " arguments";
        return false;
      }
      out += args[n];
      ++i;
    } else {
      out += pattern[i];
    }
  }
  return true;
}

}  // namespace

std::optional<Dispatch> ActionMap::map(const PlanStep& step, std::string& why) const {
  Dispatch dispatch;
  const auto rule = rules_.find(step.action);
  if (rule == rules_.end()) {
    if (step.args.empty()) {
      why = "no PEIS for '" + step.toString() + "' (no rule and no argument naming one)";
      return std::nullopt;
    }
    dispatch.peis = step.args[0];
    dispatch.goal = exec::Action{step.action, {step.args.begin() + 1, step.args.end()}}.toString();
    return dispatch;
  }
  if (!substitute(rule->second.first, step.args, dispatch.peis, why) ||
      !substitute(rule->second.second, step.args, dispatch.goal, why))
    return std::nullopt;
  if (rule->second.first == "set") {  // KEY=VALUE, written by the executor itself
    const auto eq = dispatch.goal.find('=');
    dispatch.setKey = dispatch.goal.substr(0, eq);
    dispatch.goal = dispatch.goal.substr(eq + 1);
    dispatch.peis.clear();
    return dispatch;
  }
  std::string problem;
  if (!exec::parseAction(dispatch.goal, &problem)) {
    why = "the goal '" + dispatch.goal + "' is not an action: " + problem;
    return std::nullopt;
  }
  return dispatch;
}

PlanRunner::PlanRunner(ActionMap actions, int maxReplans)
    : actions_(std::move(actions)), maxReplans_(maxReplans) {}

void PlanRunner::enter(Phase phase) {
  phase_ = phase;
  ++epoch_;
}

std::vector<Command> PlanRunner::ignore() {
  ++ignored_;
  return {};
}

std::vector<Command> PlanRunner::start(std::vector<PlanStep> plan) {
  if (phase_ != Phase::Idle && phase_ != Phase::Succeeded && phase_ != Phase::Failed)
    return ignore();
  plan_ = std::move(plan);
  step_ = 0;
  completed_.clear();
  cause_.clear();
  replans_ = 0;
  return beginStep();
}

std::vector<Command> PlanRunner::beginStep() {
  std::vector<Command> out;
  dispatch_.reset();
  goalId_.reset();
  early_.clear();
  if (step_ >= plan_.size()) {
    if (!posted_.empty()) out.push_back({Command::Kind::WithdrawNeeds, posted_, {}, {}});
    posted_.clear();
    enter(Phase::Succeeded);
    out.push_back({Command::Kind::Finished, {}, {}, "success"});
    return out;
  }
  const PlanStep& step = plan_[step_];
  // Withdraw what the previous step needed and this one does not; post what is new.
  std::vector<std::string> keep, drop, add;
  for (const auto& need : posted_)
    (std::find(step.needs.begin(), step.needs.end(), need) != step.needs.end() ? keep : drop)
        .push_back(need);
  for (const auto& need : step.needs)
    if (std::find(keep.begin(), keep.end(), need) == keep.end()) add.push_back(need);
  if (!drop.empty()) out.push_back({Command::Kind::WithdrawNeeds, drop, {}, {}});
  posted_ = step.needs;
  if (!add.empty()) {
    enter(Phase::Deploying);
    out.push_back({Command::Kind::PostNeeds, add, {}, {}});
    return out;
  }
  auto more = onDeployedNow();
  out.insert(out.end(), more.begin(), more.end());
  return out;
}

std::vector<Command> PlanRunner::onDeployed() {
  if (phase_ != Phase::Deploying) return ignore();
  return onDeployedNow();
}

std::vector<Command> PlanRunner::onDeployedNow() {
  std::string why;
  const auto dispatch = actions_.map(plan_[step_], why);
  if (!dispatch) return fail("cannot dispatch " + plan_[step_].toString() + ": " + why);
  dispatch_ = *dispatch;
  enter(Phase::Dispatching);
  return {{Command::Kind::SendGoal, {}, *dispatch, {}}};
}

std::vector<Command> PlanRunner::onDeployFailed(const std::string& cause) {
  if (phase_ != Phase::Deploying) return ignore();
  return fail("configuration for " + plan_[step_].toString() + " not deployed: " + cause);
}

std::vector<Command> PlanRunner::onGoalAccepted(std::uint64_t goalId) {
  if (phase_ != Phase::Dispatching) return ignore();
  goalId_ = goalId;
  enter(Phase::Executing);
  std::vector<Command> out;
  for (const auto& status : std::vector<exec::ExecStatus>(std::move(early_))) {
    auto more = onStatus(status);
    out.insert(out.end(), more.begin(), more.end());
  }
  early_.clear();
  return out;
}

std::vector<Command> PlanRunner::onGoalRefused(const std::string& cause) {
  if (phase_ != Phase::Dispatching) return ignore();
  return fail(plan_[step_].toString() + " refused by " + dispatch_->peis + ": " + cause);
}

std::vector<Command> PlanRunner::onStatus(const exec::ExecStatus& status) {
  if (phase_ == Phase::Dispatching) {  // the status may overtake the write's acknowledgement
    early_.push_back(status);
    return {};
  }
  if (phase_ != Phase::Executing || !goalId_ || status.goalId != *goalId_) return ignore();
  switch (status.state) {
    case exec::ExecState::Running:
      return {};
    case exec::ExecState::Success:
      completed_.push_back(plan_[step_]);
      ++step_;
      return beginStep();
    case exec::ExecState::Failed:
      return fail(plan_[step_].toString() + " failed on " + dispatch_->peis + ": " +
                  (status.cause.empty() ? "no cause given" : status.cause));
  }
  return ignore();
}

std::vector<Command> PlanRunner::fail(const std::string& cause) {
  std::vector<Command> out;
  cause_ = cause;
  if (!posted_.empty()) out.push_back({Command::Kind::WithdrawNeeds, posted_, {}, {}});
  posted_.clear();
  dispatch_.reset();
  goalId_.reset();
  if (replans_ >= maxReplans_) {
    cause_ = cause + " (gave up after " + std::to_string(replans_) + " replans)";
    enter(Phase::Failed);
    out.push_back({Command::Kind::Finished, {}, {}, "failed: " + cause_});
    return out;
  }
  ++replans_;
  enter(Phase::Replanning);
  out.push_back({Command::Kind::RequestPlan, {}, {}, cause});
  return out;
}

std::vector<Command> PlanRunner::onPlan(std::vector<PlanStep> plan) {
  if (phase_ != Phase::Replanning) return ignore();
  plan_ = std::move(plan);
  step_ = 0;
  return beginStep();
}

std::vector<Command> PlanRunner::onNoPlan(const std::string& reason) {
  if (phase_ != Phase::Replanning) return ignore();
  cause_ = cause_ + "; no new plan: " + reason;
  enter(Phase::Failed);
  return {{Command::Kind::Finished, {}, {}, "failed: " + cause_}};
}

std::vector<Command> PlanRunner::onTimeout(std::uint64_t epoch) {
  if (epoch != epoch_) return ignore();
  switch (phase_) {
    case Phase::Deploying:
      return onDeployFailed("timed out");
    case Phase::Dispatching:
      return onGoalRefused("no answer (timed out)");
    case Phase::Executing:
      return fail(plan_[step_].toString() + " on " + dispatch_->peis + " timed out");
    default:
      return ignore();
  }
}

}  // namespace peis::executor
