// The reference components as separate PEIS processes over loopback
// (issue 11's closing test and the navigation component's bad input):
// world + two ceiling cameras + tracker + a robot with navigation; the
// robot's mi-position is wired to the tracker with `peis meta`; GoTo(bed)
// ends `success` with the robot within 10 cm of the bed by the world's
// ground truth.
#include <catch2/catch.hpp>
#include <cmath>

#include "execution/exec_protocol.h"
#include "home_support.h"

using peis::test::Home;
using peis::test::programPath;
using peis::test::waitFor;
using namespace std::chrono_literals;

namespace {

std::optional<peis::exec::ExecStatus> statusOf(Home& home, peis::PeisId robot) {
  const auto t = home.observer->get(robot, "ExecStatus");
  return t ? peis::exec::parseExecStatus(t->data) : std::nullopt;
}

// Waits for the final status of goal `id`.
std::optional<peis::exec::ExecStatus> awaitEnd(Home& home, peis::PeisId robot, std::uint64_t id,
                                               std::chrono::milliseconds deadline) {
  std::optional<peis::exec::ExecStatus> status;
  waitFor(
      [&] {
        status = statusOf(home, robot);
        return status && status->goalId == id && status->state != peis::exec::ExecState::Running;
      },
      deadline);
  return status;
}

}  // namespace

TEST_CASE("GoTo(bed) with the ceiling cameras' tracker: success within 10 cm of the bed",
          "[integration]") {
  Home home("nav-bed");
  home.start(programPath("peis-sim-world"), {"--speed", "1"});
  home.start(programPath("peis-camera"), {"--camera", "living-2", "--rate", "5"});
  home.start(programPath("peis-camera"), {"--camera", "bedroom", "--rate", "5"});
  home.start(programPath("peis-tracker"),
             {"--targets", std::string(PEIS_SOURCE_DIR) + "/components/sim/homes/peis-home.yaml"});
  auto& navigation =
      home.start(programPath("peis-navigation"), {"--peis-name", "Pippi", "--base", "Pippi-base"});
  for (const char* name :
       {"world", "Pippi-base", "camera-living-2", "camera-bedroom", "tracker", "Pippi"}) {
    INFO(name << "\n" << home.describeAll());
    REQUIRE(home.await(name) != 0);
  }
  const peis::PeisId world = home.await("world");
  const peis::PeisId pippi = home.await("Pippi");
  home.observer->subscribe(peis::Pattern("physics.scene", world));
  home.observer->subscribe(peis::Pattern("ExecStatus", pippi));
  home.observer->subscribe(peis::Pattern("pose", pippi));

  // The configuration, by hand with `peis meta`: the tracker sees two cameras,
  // Pippi's navigation gets its position from the tracker.
  std::string out;
  REQUIRE(home.cli({"meta", "tracker.mi-camera1", "camera-living-2.image"}, &out) == 0);
  REQUIRE(home.cli({"meta", "tracker.mi-camera2", "camera-bedroom.image"}, &out) == 0);
  INFO(out);
  REQUIRE(home.cli({"meta", "Pippi.mi-position", "tracker.position.Pippi"}, &out) == 0);
  // Navigation localizes from the fixes before it is sent anywhere.
  REQUIRE(waitFor(
      [&] {
        const auto pose = home.observer->get(pippi, "pose");
        return pose && pose->data.find(" fix") != std::string::npos;
      },
      60s));

  const auto goal = home.observer->set(pippi, "ExecGoal", "GoTo(bed)");
  const auto status = awaitEnd(home, pippi, goal.seqno, 180s);
  INFO(home.describeAll());
  REQUIRE(status);
  CHECK(status->toString() == "success " + std::to_string(goal.seqno) + " GoTo(bed)");
  const auto truth = home.truePose(world, "Pippi");
  REQUIRE(truth);
  const double error = std::hypot((*truth)[0] - 6.6, (*truth)[1] - 4.9);
  INFO("Pippi ends at " << (*truth)[0] << ", " << (*truth)[1] << ": " << error
                        << " m from the bed");
  CHECK(error < 0.10);
  CHECK(navigation.err().find("localizing from fix") != std::string::npos);
}

TEST_CASE("navigation's bad input over the network: refused goals, no path, a replaced goal",
          "[integration]") {
  Home home("nav-bad");
  home.start(programPath("peis-sim-world"), {"--speed", "2"});
  auto& navigation =
      home.start(programPath("peis-navigation"), {"--peis-name", "Emil", "--base", "Emil-base"});
  const peis::PeisId emil = home.await("Emil");
  REQUIRE(emil != 0);
  REQUIRE(home.await("world") != 0);
  home.observer->subscribe(peis::Pattern("ExecStatus", emil));
  // A malformed goal is refused at the gate with the reason.
  try {
    home.observer->set(emil, "ExecGoal", "GoTo(bed");
    FAIL("a malformed ExecGoal was accepted");
  } catch (const peis::Error& e) {
    CHECK(e.code() == peis::ErrorCode::Refused);
    CHECK(std::string(e.what()).find("expected ')'") != std::string::npos);
  }
  CHECK_THROWS_AS(home.observer->set(emil, "ExecGoal", "Fly(moon)"), peis::Error);
  // Inside the wardrobe: not reachable.
  auto goal = home.observer->set(emil, "ExecGoal", "GoTo(5.65, 5.65)");
  auto status = awaitEnd(home, emil, goal.seqno, 60s);
  REQUIRE(status);
  CHECK(status->cause == "goal blocked");
  goal = home.observer->set(emil, "ExecGoal", "GoTo(attic)");
  status = awaitEnd(home, emil, goal.seqno, 60s);
  REQUIRE(status);
  CHECK(status->cause == "unknown place 'attic'");
  goal = home.observer->set(emil, "ExecGoal", "GoTo(20, 3)");
  status = awaitEnd(home, emil, goal.seqno, 60s);
  REQUIRE(status);
  CHECK(status->cause == "goal outside the map");
  // A goal while another runs replaces it.
  const auto first = home.observer->set(emil, "ExecGoal", "GoTo(kitchen)");
  REQUIRE(waitFor([&] {
    const auto s = statusOf(home, emil);
    return s && s->goalId == first.seqno;
  }));
  const auto second = home.observer->set(emil, "ExecGoal", "GoTo(bedroom-door)");
  status = awaitEnd(home, emil, second.seqno, 120s);
  INFO(navigation.describe());
  REQUIRE(status);
  CHECK(status->state == peis::exec::ExecState::Success);
}
