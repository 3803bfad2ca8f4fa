// peis-vacuum: the vacuum cleaner (Fig. 1 of both papers). `Clean(<room>)`
// written to its ExecGoal covers the room lane by lane with the navigation
// core; it needs its position from the ecology (mi-position, e.g. the
// ceiling-camera tracker: its own odometry is too poor) and decides from an
// obstacle's weight (mi-weight, e.g. the parcel's Weight through the
// tinybridge) whether to push it or go around. docs/components/vacuum.md.
#include <peis/component.h>

#include <cmath>
#include <iostream>
#include <memory>

#include "coverage.h"
#include "execution/exec_server.h"
#include "execution/program_options.h"
#include "robot_link.h"
#include "vacuum_descriptor.h"

namespace {

const char* kUsage = R"usage(Usage: peis-vacuum [OPTIONS] [--peis-* flags]

The vacuum cleaner: ExecGoal Clean(<room>) covers the room (room.<room> of the
map server) lane by lane. Needs a fresh position on mi-position to start (a
configured input that has not delivered yet is waited for, --position-wait);
pushes an obstacle whose weight (mi-weight, grams) is at most --push-kg and goes
around anything heavier or of unknown weight.

Options:
  --base NAME        the driver PEIS (default: <peis name>-base)
  --map-server NAME  the map server PEIS (default: world)
  --push-kg KG       the heaviest obstacle to push (default 1.0)
  --spacing M        metres between lanes (default: the robot's diameter)
  --position-wait S  seconds a configured mi-position may take to deliver its
                     first fresh position before Clean fails (default 10)
  --help             this text
)usage";

}  // namespace

int main(int argc, char** argv) {
  if (peis::exec::printedHelp(argc, argv, kUsage)) return 0;
  peis::Kernel kernel(argc, argv);
  peis::nav::RobotLinkSettings link;
  link.logPrefix = "vacuum";
  double pushKg = 1.0, spacing = 0, positionWait = 10;
  const int code = peis::exec::parseProgramOptions(
      argc, argv, "peis-vacuum", kUsage, [&](const std::string& name, const std::string& value) {
        const auto number = peis::exec::parseNumber(value);
        if (name == "--base")
          link.base = value;
        else if (name == "--map-server")
          link.mapServer = value;
        else if (name == "--push-kg" && number && *number >= 0)
          pushKg = *number;
        else if (name == "--spacing" && number && *number > 0)
          spacing = *number;
        else if (name == "--position-wait" && number && *number >= 0 && *number <= 3600)
          positionWait = *number;
        else
          return false;
        return true;
      });
  if (code >= 0) return code;
  if (link.base.empty()) link.base = kernel.name() + "-base";
  link.robot = peis::nav::robotNameOfDriver(link.base);
  peis::Component component(kernel, "vacuum",
                            peis::Descriptor::fromYaml(kVacuumDescriptor, "vacuum.yaml"));

  struct Run {
    std::uint64_t goalId = 0;
    std::string action;
    std::vector<peis::nav::Point2> waypoints;
    std::size_t next = 0, reached = 0;
    std::uint64_t legId = 0;  // the navigator's id of the current leg
  };
  std::optional<Run> run;
  // A Clean waiting for the first fresh position of a configured mi-position.
  struct Waiting {
    peis::exec::Action action;
    std::uint64_t goalId = 0;
    std::chrono::steady_clock::time_point until;
  };
  std::optional<Waiting> waiting;
  std::function<void(const peis::exec::Action&, std::uint64_t)> begin;
  std::uint64_t legIds = 1ull << 40;  // navigator leg ids, apart from ExecGoal seqnos
  std::unique_ptr<peis::exec::ExecServer> server;
  std::unique_ptr<peis::nav::RobotLink> robot;
  std::function<void()> nextLeg;

  auto progress = [&] {
    if (run)
      kernel.set("clean.progress", std::to_string(run->reached) + " of " +
                                       std::to_string(run->waypoints.size()) + " lane ends");
  };
  // The cleaner works close to the furniture, where a ceiling camera sees
  // its low hat partly hidden and the fix is a few centimetres off: it keeps
  // 6 cm more than its radius from what the map holds (not 2), so a biased
  // fix does not wedge it against the sofa, bumping at every lane end.
  peis::nav::NavigatorOptions navigation;
  navigation.inflation.safetyMargin = 0.06;
  robot = std::make_unique<peis::nav::RobotLink>(
      kernel, link, navigation, [&](const peis::exec::ExecStatus& status) {
        if (!run || status.goalId != run->legId || status.state == peis::exec::ExecState::Running)
          return;
        if (status.state == peis::exec::ExecState::Success)
          ++run->reached;
        else
          robot->log("lane end skipped: " + status.cause);
        progress();
        nextLeg();
      });
  nextLeg = [&] {
    if (!run) return;
    if (run->next >= run->waypoints.size()) {
      server->publish({peis::exec::ExecState::Success, run->goalId, run->action, ""});
      run.reset();
      return;
    }
    const auto p = run->waypoints[run->next++];
    char args[2][32];
    std::snprintf(args[0], sizeof args[0], "%.3f", p.x);
    std::snprintf(args[1], sizeof args[1], "%.3f", p.y);
    run->legId = ++legIds;
    robot->apply(robot->navigator().onGoal({"GoTo", {args[0], args[1]}}, run->legId));
  };
  auto applyWeight = [&] {
    const auto weight = component.inputValue("weight");
    const auto grams = weight ? peis::exec::parseNumber(weight->data) : std::nullopt;
    const auto decision = peis::devices::decideObstacle(
        grams && component.inputFresh("weight") ? std::optional<long>(std::lround(*grams))
                                                : std::nullopt,
        pushKg);
    if (robot->navigator().pushObstacles() != decision.push || !kernel.get("obstacle.decision"))
      robot->log("obstacles: " + decision.reason);
    robot->navigator().setPushObstacles(decision.push);
    kernel.set("obstacle.decision", decision.reason);
  };

  server = std::make_unique<peis::exec::ExecServer>(
      kernel,
      [](const peis::exec::Action& a) -> std::optional<std::string> {
        if (a.name == "Stop" && a.args.empty()) return std::nullopt;
        if (a.name != "Clean" || a.args.size() != 1)
          return "the vacuum does Clean(<room>) and Stop";
        return std::nullopt;
      },
      [&](const peis::exec::Action& a, std::uint64_t id) {
        if (run) {
          server->publish({peis::exec::ExecState::Failed, run->goalId, run->action,
                           "replaced by goal " + std::to_string(id)});
          run.reset();
          robot->apply(robot->navigator().onGoal({"Stop", {}}, ++legIds));
        }
        if (waiting) {
          server->publish({peis::exec::ExecState::Failed, waiting->goalId,
                           waiting->action.toString(), "replaced by goal " + std::to_string(id)});
          waiting.reset();
        }
        if (a.name == "Stop")
          return server->publish({peis::exec::ExecState::Success, id, "Stop", ""});
        // Just configured (a configurator pointed mi-position somewhere): the
        // first position may be on its way.
        const auto meta = kernel.get("mi-position");
        if (!component.inputFresh("position") && meta && !meta->data.empty() && positionWait > 0) {
          server->publish({peis::exec::ExecState::Running, id, a.toString(), ""});
          robot->log("waiting for a first position from " + meta->data);
          waiting = Waiting{a, id,
                            std::chrono::steady_clock::now() +
                                std::chrono::milliseconds(static_cast<long>(positionWait * 1000))};
          return;
        }
        begin(a, id);
      });
  kernel.every(std::chrono::milliseconds(100), [&] {
    if (!waiting) return;
    if (component.inputFresh("position")) {
      const Waiting w = *waiting;
      waiting.reset();
      return begin(w.action, w.goalId);
    }
    if (std::chrono::steady_clock::now() < waiting->until) return;
    server->publish({peis::exec::ExecState::Failed, waiting->goalId, waiting->action.toString(),
                     "no position: mi-position delivered none in time (--position-wait)"});
    waiting.reset();
  });
  begin = [&](const peis::exec::Action& a, std::uint64_t id) {
    auto failed = [&](const std::string& cause) {
      server->publish({peis::exec::ExecState::Failed, id, a.toString(), cause});
    };
    if (!component.inputFresh("position"))
      return failed("no position: mi-position is not configured or stale");
    const auto roomTuple = robot->mapServerTuple("room." + a.args[0]);
    const auto room = roomTuple ? peis::devices::parsePolygon(roomTuple->data) : std::nullopt;
    if (!room) return failed("unknown room '" + a.args[0] + "'");
    if (!robot->navigator().hasMap()) return failed("no map");
    const auto& costmap = robot->navigator().costmap();
    const double lanes = spacing > 0 ? spacing : 2 * costmap.options().robotRadius;
    run = Run{id, a.toString(), peis::devices::coverageWaypoints(costmap, *room, lanes), 0, 0, 0};
    server->publish({peis::exec::ExecState::Running, id, a.toString(), ""});
    robot->log("cleaning " + a.args[0] + ": " + std::to_string(run->waypoints.size()) +
               " lane ends");
    progress();
    nextLeg();
  };
  component.input("position", std::chrono::seconds(2),
                  [&](const peis::Tuple& t) { robot->onFix(t); });
  component.input("weight", std::chrono::seconds(30), [&](const peis::Tuple&) { applyWeight(); });
  kernel.every(std::chrono::milliseconds(500), applyWeight);  // a stale weight counts as unknown
  robot->start();
  component.start();
  kernel.run();
  return 0;
}
