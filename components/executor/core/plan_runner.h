// The plan executor's state machine, without a network: runs a plan of the
// task planner step by step, as javaspace-peis-middleware.txt §5 runs Emil's
// plan on Pippi. For each step:
//
//   deploying ──deployed──▶ dispatching ──accepted──▶ executing ──success──▶ next step
//   (post the step's         (write ExecGoal to         (follow its          (withdraw the needs
//    configuration needs)     the executing PEIS)        ExecStatus)          the next step lacks)
//
// Any failure (the configuration cannot be deployed, the ExecGoal is refused,
// the ExecStatus says failed, a phase times out) withdraws the step's needs
// and asks for a new plan from the current state; a new plan starts over, no
// plan (or too many replans) ends the run `failed` with the cause. The runner
// only emits commands; the shell carries them out and feeds the results back.
// Events that do not fit the phase are ignored and counted.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "execution/exec_protocol.h"

namespace peis::executor {

// One step of a plan (the task planner's Step): `GoTo(pippi, bed)` with the
// configuration goals it needs while it runs (`position(pippi)@Pippi.mi-position`).
struct PlanStep {
  std::string action;
  std::vector<std::string> args;
  std::vector<std::string> needs;
  std::string toString() const;  // `GoTo(pippi, bed)`
  bool operator==(const PlanStep&) const = default;
};

// Where a step is executed, and the ExecGoal written there.
// A rule `set:KEY=VALUE` is carried out by the executor itself: it writes its
// own tuple KEY = VALUE (`TurnOn=set:LightValue=100`: Astrid sets
// <6890, LightValue, 100>, which the lamp's tiny node listens to), and the
// step succeeds once written.
struct Dispatch {
  std::string peis;      // PEIS name or id; empty with setKey
  std::string goal;      // ExecGoal text, e.g. `GoTo(bed)`; with setKey: the value
  std::string setKey{};  // non-empty: write this own tuple instead of an ExecGoal
  bool operator==(const Dispatch&) const = default;
};

// Action name -> the PEIS and ExecGoal templates, with `$1`, `$2`… standing
// for the step's arguments: `GoTo=$1:GoTo($2)` sends `GoTo(pippi, bed)` to
// PEIS `pippi` as `GoTo(bed)`. An action without a rule uses the default:
// PEIS = the first argument, goal = the action with the other arguments.
class ActionMap {
 public:
  // Parses `NAME=PEIS:GOAL` or `NAME=set:KEY=VALUE`; throws
  // std::invalid_argument naming the problem.
  void add(const std::string& rule);
  // The dispatch of a step, or nothing with the reason in `why`.
  std::optional<Dispatch> map(const PlanStep& step, std::string& why) const;

 private:
  std::map<std::string, std::pair<std::string, std::string>> rules_;
};

enum class Phase { Idle, Deploying, Dispatching, Executing, Replanning, Succeeded, Failed };
const char* toString(Phase phase);

struct Command {
  enum class Kind {
    PostNeeds,      // post `needs` to the configurator for `step`
    WithdrawNeeds,  // withdraw `needs`
    SendGoal,       // write `dispatch.goal` to `dispatch.peis`.ExecGoal
    RequestPlan,    // plan again from the state after `completed` steps
    Finished,       // the run ended: `text` is `success` or `failed: <cause>`
  };
  Kind kind;
  std::vector<std::string> needs;
  Dispatch dispatch;
  std::string text;
  bool operator==(const Command&) const = default;
};

class PlanRunner {
 public:
  explicit PlanRunner(ActionMap actions, int maxReplans = 3);

  std::vector<Command> start(std::vector<PlanStep> plan);
  std::vector<Command> onDeployed();
  std::vector<Command> onDeployFailed(const std::string& cause);
  std::vector<Command> onGoalAccepted(std::uint64_t goalId);
  std::vector<Command> onGoalRefused(const std::string& cause);
  std::vector<Command> onStatus(const exec::ExecStatus& status);
  std::vector<Command> onPlan(std::vector<PlanStep> plan);
  std::vector<Command> onNoPlan(const std::string& reason);
  // A phase timer the shell armed at `epoch` ran out.
  std::vector<Command> onTimeout(std::uint64_t epoch);

  Phase phase() const { return phase_; }
  // Changes with every phase change: a timer armed at an older epoch is stale.
  std::uint64_t epoch() const { return epoch_; }
  const std::vector<PlanStep>& plan() const { return plan_; }
  std::size_t stepIndex() const { return step_; }
  // The steps done so far, over all plans, in order.
  const std::vector<PlanStep>& completed() const { return completed_; }
  const std::string& cause() const { return cause_; }
  int replans() const { return replans_; }
  std::uint64_t ignoredEvents() const { return ignored_; }
  std::optional<std::uint64_t> goalId() const { return goalId_; }

 private:
  void enter(Phase phase);
  std::vector<Command> beginStep();
  std::vector<Command> onDeployedNow();
  std::vector<Command> fail(const std::string& cause);
  std::vector<Command> ignore();

  ActionMap actions_;
  int maxReplans_;
  Phase phase_ = Phase::Idle;
  std::uint64_t epoch_ = 0;
  std::vector<PlanStep> plan_;
  std::size_t step_ = 0;
  std::vector<std::string> posted_;  // needs deployed now
  std::optional<Dispatch> dispatch_;
  std::optional<std::uint64_t> goalId_;
  std::vector<exec::ExecStatus> early_;  // statuses seen before the goal's id was known
  std::vector<PlanStep> completed_;
  std::string cause_;
  int replans_ = 0;
  std::uint64_t ignored_ = 0;
};

}  // namespace peis::executor
