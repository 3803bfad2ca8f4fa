// peis-executor: the plan executor PEIS-component. Runs a plan (from
// --plan or its `plan` tuple, or planned by the meta-level's task planner
// for a task written to its `task` tuple) with the PlanRunner state machine:
// deploys each step's configuration needs, writes the step's ExecGoal to the
// PEIS that executes it, follows that PEIS's ExecStatus, withdraws the needs,
// and on a failure replans (from the state the steps done so far reached,
// with --domain and --problem; else it retries the remaining steps).
// docs/components/executor.md.
#include <peis/component.h>

#include <iostream>
#include <map>
#include <memory>

#include "configurator_link.h"
#include "execution/exec_server.h"
#include "execution/program_options.h"
#include "executor_descriptor.h"
#include "peis/error.h"
#include "plan_runner.h"
#include "plan_text.h"
#include "task_planning.h"

namespace {

const char* kUsage = R"usage(Usage: peis-executor [OPTIONS] [--peis-* flags]

Runs a plan: for each step, deploys the configuration it needs, writes the
step's ExecGoal to the PEIS that executes it and follows that PEIS's ExecStatus.

Options:
  --plan PLAN         the plan to run at start: STEP; STEP; ... where a STEP is
                      ACTION [| NEED ...], e.g.
                      "GoTo(Pippi, bed) | position(pippi)@Pippi.mi-position; Talk(Pippi, wakeup)"
                      (a plan written later to this PEIS's `plan` tuple runs too)
  --action RULE       NAME=PEIS:GOAL with $1..$9 for the step's arguments, e.g.
                      Talk=$1-voice:Talk($2); or NAME=set:KEY=VALUE: the executor
                      writes its own tuple KEY (TurnOn=set:LightValue=100) and
                      the step succeeds; repeatable. Without a rule a step
                      goes to the PEIS its first argument names.
  --link LINK         INFORMATION=PEIS.KEY: the static configuration that
                      serves needs, e.g. position(pippi)=tracker.position.Pippi
  --configurator KIND static (default: the --link table) or goal-tuples (post
                      the needs as this PEIS's config.goal.<name> tuple for
                      peis-configurator; deployed when its config.goal-status
                      says so)
  --domain FILE       the task domain (meta/domains/home.domain.yaml): tasks
                      written to the `task` tuple are planned with it, and a
                      failure is replanned from the state reached
  --problem FILE      the objects and the initial state the tasks start from
                      (its goal is not used)
  --task GOALS        a task to plan and run at start, e.g.
                      "awake(johanna), at(pippi, sofa)" (needs --domain, --problem)
  --replans N         failures retried before giving up (default 2)
  --deploy-timeout S  seconds for a step's configuration (default 15)
  --step-timeout S    seconds for a step's action (default 600)
  --exit              exit when the plan ends: 0 on success, 1 on failure (once
                      the consumers acknowledged the withdrawals, at most 10 s)
  --help              this text

Tuples: plan (in), task (in: goal literals), task.plan (the plan found),
plan.status (running / success / failed: CAUSE), plan.step.
)usage";

struct Settings {
  std::string plan;
  peis::executor::ActionMap actions;
  std::vector<peis::executor::StaticLink> links;
  int replans = 2;
  double deployTimeout = 15, stepTimeout = 600;
  bool exitWhenDone = false;
  std::string configurator = "static";
  std::string domainPath, problemPath, task;
};

bool takeOption(Settings& s, const std::string& name, const std::string& value) {
  if (name == "--exit") {
    s.exitWhenDone = true;
  } else if (name == "--plan") {
    peis::executor::parsePlan(value);  // throws on a malformed plan
    s.plan = value;
  } else if (name == "--action") {
    s.actions.add(value);
  } else if (name == "--link") {
    s.links.push_back(peis::executor::parseStaticLink(value));
  } else if (name == "--configurator") {
    if (value != "static" && value != "goal-tuples")
      throw std::invalid_argument("--configurator takes static or goal-tuples");
    s.configurator = value;
  } else if (name == "--domain") {
    s.domainPath = value;
  } else if (name == "--problem") {
    s.problemPath = value;
  } else if (name == "--task") {
    peis::executor::parseTask(value);  // throws on a malformed task
    s.task = value;
  } else if (name == "--replans" || name == "--deploy-timeout" || name == "--step-timeout") {
    const auto number = peis::exec::parseNumber(value);
    if (!number || *number < 0) throw std::invalid_argument(name + " takes a non-negative number");
    if (name == "--replans") s.replans = static_cast<int>(*number);
    if (name == "--deploy-timeout") s.deployTimeout = *number;
    if (name == "--step-timeout") s.stepTimeout = *number;
  } else {
    return false;
  }
  return true;
}

using peis::executor::Command;
using peis::executor::Phase;

// The shell: carries out the runner's commands on the kernel thread.
struct Shell {
  peis::Kernel& kernel;
  Settings settings;
  peis::executor::PlanRunner runner;
  std::unique_ptr<peis::executor::ConfiguratorLink> configurator;
  std::map<peis::PeisId, peis::CallbackHandle> watched;  // ExecStatus callbacks by PEIS
  int exitCode = -1;
  int withdrawalsUnacknowledged = 0;
  std::string quitReason;  // set when the program leaves after the plan
  // With --domain and --problem: the task being run (its goal literals).
  std::optional<peis::meta::task::Domain> domain;
  std::optional<peis::meta::task::Problem> problem;
  std::vector<peis::meta::task::Literal> goal;
  // The task's failed steps so far: what each taught is kept for every replan.
  std::vector<peis::executor::FailedStep> failures{};

  void log(const std::string& line) { std::cerr << "executor: " << line << std::endl; }

  void publishPhase() {
    std::string text;
    switch (runner.phase()) {
      case Phase::Succeeded:
        text = "success";
        break;
      case Phase::Failed:
        text = "failed: " + runner.cause();
        break;
      case Phase::Idle:
        text = "idle";
        break;
      default:
        text = std::string("running ") + toString(runner.phase()) + " step " +
               std::to_string(runner.stepIndex() + 1) + "/" + std::to_string(runner.plan().size());
    }
    kernel.set("plan.status", text);
    if (runner.stepIndex() < runner.plan().size())
      kernel.set("plan.step", runner.plan()[runner.stepIndex()].toString());
  }

  void apply(const std::vector<Command>& commands) {
    const auto epochBefore = runner.epoch();
    for (const auto& c : commands) carryOut(c);
    publishPhase();
    if (runner.epoch() != epochBefore) armTimer();
  }

  void armTimer() {
    double seconds = 0;
    if (runner.phase() == Phase::Deploying) seconds = settings.deployTimeout;
    if (runner.phase() == Phase::Dispatching) seconds = 15;
    if (runner.phase() == Phase::Executing) seconds = settings.stepTimeout;
    if (seconds <= 0) return;
    const auto epoch = runner.epoch();
    kernel.after(std::chrono::milliseconds(static_cast<long>(seconds * 1000)),
                 [this, epoch] { apply(runner.onTimeout(epoch)); });
  }

  void watch(peis::PeisId id) {
    if (watched.count(id)) return;
    kernel.subscribe(peis::Pattern("ExecStatus", id));
    watched[id] = kernel.onChange(peis::Pattern("ExecStatus", id), [this](const peis::Tuple& t) {
      const auto status = peis::exec::parseExecStatus(t.data);
      if (!status) return log("unreadable ExecStatus '" + t.data + "' ignored");
      log("ExecStatus of " + std::to_string(t.owner) + ": " + t.data);
      apply(runner.onStatus(*status));
    });
  }

  void carryOut(const Command& c) {
    switch (c.kind) {
      case Command::Kind::PostNeeds:
        log("deploying " + join(c.needs));
        configurator->post(c.needs, [this](const std::optional<std::string>& error) {
          kernel.post([this, error] {
            apply(error ? runner.onDeployFailed(*error) : runner.onDeployed());
          });
        });
        break;
      case Command::Kind::WithdrawNeeds:
        log("withdrawing " + join(c.needs));
        ++withdrawalsUnacknowledged;
        configurator->withdraw(c.needs, [this](const std::optional<std::string>& error) {
          if (error) log("withdrawal not acknowledged: " + *error);
          if (--withdrawalsUnacknowledged == 0 && !quitReason.empty()) kernel.quit(quitReason);
        });
        break;
      case Command::Kind::SendGoal: {
        // A PEIS that has not joined yet gets a while (a plan may start first).
        const auto dispatch = c.dispatch;
        if (!dispatch.setKey.empty()) {  // carried out here: an own tuple written
          log("sets " + dispatch.setKey + " = " + dispatch.goal);
          const std::uint64_t seqno = kernel.set(dispatch.setKey, dispatch.goal).seqno;
          kernel.post([this, seqno, dispatch] {
            apply(runner.onGoalAccepted(seqno));
            apply(runner.onStatus({peis::exec::ExecState::Success, seqno,
                                   dispatch.setKey + "=" + dispatch.goal, ""}));
          });
          break;
        }
        peis::exec::resolvePeer(
            kernel, dispatch.peis, std::chrono::seconds(10),
            [this, dispatch](std::optional<peis::PeisId> id) {
              if (!id)
                return apply(runner.onGoalRefused("no PEIS named '" + dispatch.peis + "' joined"));
              watch(*id);
              log("ExecGoal " + dispatch.peis + " <- " + dispatch.goal);
              kernel.setAsync(*id, peis::exec::kExecGoal, dispatch.goal, {},
                              [this](const std::optional<peis::Error>& error, std::uint64_t seqno) {
                                apply(error ? runner.onGoalRefused(error->what())
                                            : runner.onGoalAccepted(seqno));
                              });
            });
        break;
      }
      case Command::Kind::RequestPlan: {
        log("replanning after: " + c.text);
        if (domain && problem && !goal.empty()) {
          // The task planner, from the state the steps done so far reached
          // and what the failed step's cause tells (its action's on-failure).
          if (runner.stepIndex() < runner.plan().size())
            failures.push_back(
                {runner.plan()[runner.stepIndex()], c.text, runner.completed().size()});
          kernel.post([this] {
            try {
              const auto planned =
                  peis::executor::planFrom(*domain, *problem, goal, runner.completed(), failures);
              log(planned.found ? "new plan: " + planned.text : "no plan: " + planned.text);
              if (planned.found) kernel.set("task.plan", planned.text);
              apply(planned.found ? runner.onPlan(planned.steps) : runner.onNoPlan(planned.text));
            } catch (const std::exception& e) {
              apply(runner.onNoPlan(e.what()));
            }
          });
          break;
        }
        // A plan given as it is: the new plan is its rest, from the failed step (a retry).
        std::vector<peis::executor::PlanStep> rest(
            runner.plan().begin() + static_cast<long>(runner.stepIndex()), runner.plan().end());
        kernel.post([this, rest] { apply(runner.onPlan(rest)); });
        break;
      }
      case Command::Kind::Finished:
        log("plan " + c.text);
        if (settings.exitWhenDone) {
          exitCode = runner.phase() == Phase::Succeeded ? 0 : 1;
          // Leaves once the consumers acknowledged the withdrawals, so none
          // is lost with this process (a remote write is retried meanwhile);
          // a consumer that never answers holds it up at most 10 s.
          quitReason = "plan " + c.text;
          if (withdrawalsUnacknowledged == 0) {
            kernel.quit(quitReason);
          } else {
            log("waiting for " + std::to_string(withdrawalsUnacknowledged) +
                " withdrawal(s) to be acknowledged");
            kernel.after(std::chrono::seconds(10), [this] { kernel.quit(quitReason); });
          }
        }
        break;
    }
  }

  static std::string join(const std::vector<std::string>& items) {
    std::string out;
    for (const auto& i : items) out += (out.empty() ? "" : ", ") + i;
    return out;
  }

  void startTask(const std::string& text) {
    try {
      goal = peis::executor::parseTask(text);
      failures.clear();
      const auto planned = peis::executor::planFrom(*domain, *problem, goal);
      if (!planned.found) {
        log("task " + text + ": no plan: " + planned.text);
        kernel.set("task.plan", "");
        kernel.set("plan.status", "failed: no plan for " + text + ": " + planned.text);
        return;
      }
      log("task " + text + ": plan " + planned.text);
      kernel.set("task.plan", planned.text);
      apply(runner.start(planned.steps));
    } catch (const std::exception& e) {
      log(std::string("task refused: ") + e.what());
      kernel.set("plan.status", std::string("failed: ") + e.what());
    }
  }

  void startPlan(const std::string& text) {
    goal.clear();
    failures.clear();
    try {
      auto plan = peis::executor::parsePlan(text);
      log("running plan: " + peis::executor::formatPlan(plan));
      apply(runner.start(std::move(plan)));
    } catch (const std::invalid_argument& e) {
      log(std::string("plan refused: ") + e.what());
      kernel.set("plan.status", std::string("failed: ") + e.what());
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (peis::exec::printedHelp(argc, argv, kUsage)) return 0;
  peis::Kernel kernel(argc, argv);
  Settings settings;
  if (const int code =
          peis::exec::parseProgramOptions(argc, argv, "peis-executor", kUsage,
                                          [&settings](const std::string& n, const std::string& v) {
                                            return takeOption(settings, n, v);
                                          },
                                          {"--exit"});
      code >= 0)
    return code;
  if (!settings.task.empty() && (settings.domainPath.empty() || settings.problemPath.empty())) {
    std::cerr << "peis-executor: --task needs --domain and --problem (see --help)\n";
    return 2;
  }
  peis::Component component(kernel, "executor",
                            peis::Descriptor::fromYaml(kExecutorDescriptor, "executor.yaml"));
  Shell shell{kernel,
              settings,
              peis::executor::PlanRunner(settings.actions, settings.replans),
              nullptr,
              {},
              -1,
              0,
              {},
              std::nullopt,
              std::nullopt,
              {}};
  try {
    if (!settings.domainPath.empty())
      shell.domain = peis::meta::task::Domain::fromFile(settings.domainPath);
    if (!settings.problemPath.empty())
      shell.problem = peis::meta::task::Problem::fromFile(settings.problemPath);
  } catch (const peis::Error& e) {
    std::cerr << "peis-executor: " << e.what() << "\n";
    return 1;
  }
  const bool tasks = shell.domain && shell.problem;
  if (settings.configurator == "goal-tuples")
    shell.configurator = std::make_unique<peis::executor::GoalTupleConfigurator>(
        kernel, "config.goal." + kernel.name(),
        std::chrono::milliseconds(static_cast<long>(settings.deployTimeout * 1000)));
  else
    shell.configurator =
        std::make_unique<peis::executor::StaticConfigurator>(kernel, settings.links);
  // A plan written to `plan` (locally or remotely) starts a run; a malformed
  // one is refused at the gate.
  kernel.setWriteGate(
      [tasks](const peis::Tuple& t, peis::PeisId, const peis::WriteDecision& decide) {
        if (t.key != "plan" && t.key != "task") return false;
        try {
          if (t.key == "plan") peis::executor::parsePlan(t.data);
          if (t.key == "task" && !tasks)
            throw std::invalid_argument(
                "this executor plans no tasks (it has no --domain and --problem)");
          if (t.key == "task") peis::executor::parseTask(t.data);
          return false;
        } catch (const std::invalid_argument& e) {
          decide(peis::Error(peis::ErrorCode::Refused, e.what()));
          return true;
        }
      });
  kernel.onChange(peis::Pattern::exact(kernel.id(), "plan"),
                  [&shell](const peis::Tuple& t) { shell.startPlan(t.data); });
  if (tasks)
    kernel.onChange(peis::Pattern::exact(kernel.id(), "task"),
                    [&shell](const peis::Tuple& t) { shell.startTask(t.data); });
  component.start();
  if (!settings.plan.empty()) kernel.set("plan", settings.plan);
  if (!settings.task.empty()) kernel.set("task", settings.task);
  kernel.run();
  return shell.exitCode < 0 ? 0 : shell.exitCode;
}
