// The three reference scenarios (scenarios/*.yaml) end to end, with the
// meta-level's configurator: each at the fastest --speed at which it stays
// correct (docs/scenarios.md says how that was found), and each again with
// a fault injected that it must survive. Nothing is deployed by the test:
// the configurator plans and deploys every configuration, the executors'
// task planner plans every step.
#include <peis/kernel.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <regex>

#include "support/process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

using Catch::Matchers::Contains;
using peis::test::Process;
using peis::test::waitFor;
using namespace std::chrono_literals;

namespace {

std::string scenario(const std::string& name) {
  return std::string(PEIS_SOURCE_DIR) + "/scenarios/" + name + ".yaml";
}

struct Run {
  int status = -1;
  std::string out, err;
};

Run run(std::vector<std::string> args, std::chrono::seconds deadline) {
  args.insert(args.begin(), PEIS_SCENARIO_PATH);
  Process p(args);
  const auto status = p.wait(deadline);
  INFO(p.describe());
  REQUIRE(status.has_value());
  return Run{*status, p.out(), p.err()};
}

bool held(const std::string& out, const std::string& condition) {
  return out.find("  held      " + condition + " (") != std::string::npos;
}

// The speeds the tests run at (docs/scenarios.md, "Tests").
constexpr const char* kPhotoSpeed = "16";
constexpr const char* kWakeSpeed = "16";
constexpr const char* kVacuumSpeed = "16";

}  // namespace

TEST_CASE("reference scenarios: the three files are valid and name the configurator",
          "[integration][scenario]") {
  for (const char* name : {"photo-sofa", "wake-up", "vacuum-parcel"}) {
    const Run without = run({"check", scenario(name), "--without", "configurator"}, 60s);
    INFO(without.out << without.err);
    CHECK(without.status == 0);
    // The meta-level's configurator is built (peis-configurator): the files
    // are valid with it too.
    const Run with = run({"check", scenario(name)}, 60s);
    INFO(with.out << with.err);
    CHECK(with.status == 0);
    CHECK_THAT(with.out, Contains("valid"));
  }
}

void checkPhotoSofa(const Run& r) {
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  // The tiny part of section V: <3, 43, 0> from the plant closes the blind.
  CHECK_THAT(r.out, Contains("too much sun on the plant: it sends <3, 43, 0> to the blind"));
  // GoTo's position: deployed by the configurator, not by anyone's hand.
  CHECK_THAT(r.out, Contains("astrid           configuration: mi-position now reads "
                             "tracker.position.Astrid"));
  // The dark photo is replanned by the task planner: the lamp lights the sofa.
  CHECK_THAT(r.out, Contains("Astrid's plan: GoTo(astrid, sofa); TakePhoto(astrid, sofa)"));
  CHECK_THAT(r.out, Contains("Astrid's plan: TurnOn(lamp); TakePhoto(astrid, sofa)"));
  CHECK_THAT(r.out, Contains("Astrid asks the configurator for: lamp-level(lamp)"));
  for (const char* condition :
       {"the plant asks the blind to close", "the blind closes", "a photo is too dark",
        "Astrid sets <6890, LightValue, 100>", "the lamp turns on", "the photo is bright enough",
        "the task completes"})
    CHECK(held(r.out, condition));
}

TEST_CASE("reference scenarios: photo-sofa (the dark photo, the lamp through the bridge)",
          "[integration][scenario]") {
  peis::test::TempDir dir;
  const auto trace = dir.path / "photo-sofa.trace.sqlite";
  const auto picture = dir.path / "photo-sofa.png";
  const Run r = run({"run", scenario("photo-sofa"), "--speed", kPhotoSpeed, "--trace",
                     trace.string(), "--picture", picture.string()},
                    280s);
  checkPhotoSofa(r);
  CHECK(std::filesystem::file_size(trace) > 0);
  CHECK(std::filesystem::file_size(picture) > 0);
}

TEST_CASE("reference scenarios: photo-sofa survives the lamp's radio link cut for a while",
          "[fault][scenario]") {
  const Run r = run({"run", scenario("photo-sofa"), "--speed", kPhotoSpeed, "--trace", "",
                     "--picture", "", "--inject", "cut lamp at 5 for 6"},
                    280s);
  CHECK_THAT(r.out, Contains("FAULT: radio link cut for 6.0 s"));
  CHECK_THAT(r.out, Contains("radio link restored"));
  checkPhotoSofa(r);
}

void checkWakeUp(const Run& r) {
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK_THAT(r.out, Contains("pippi            configuration: mi-position now reads "
                             "tracker.position.Pippi"));
  // The bedroom's camera is killed (the file's fault): the configurator
  // re-deploys the tracker on the other camera alone, within a second or so.
  // Which of its two inputs had the bedroom's camera is the planner's choice
  // among equals (the file says so), so either may be the one emptied.
  CHECK_THAT(r.out, Contains("camera-bedroom   FAULT: kill -9"));
  CHECK(
      std::regex_search(r.out, std::regex("tracker +configuration: mi-camera[12] now reads nothing "
                                          "\\([0-9.]+ s after kill camera-bedroom at 6\\)")));
  for (const char* condition :
       {"Emil plans GoTo(bed), Talk(wakeup), GoTo(sofa)", "GoTo's position comes from the tracker",
        "Pippi localizes from the tracker's fixes",
        "the tracker is re-deployed on the living room's camera alone",
        "out of the cameras' view, Pippi carries on with odometry",
        "back in view, Pippi localizes from fixes again", "Pippi reaches the bed within 15 cm",
        "Johanna wakes up", "Pippi reaches the sofa within 15 cm",
        "Pippi reports completion to Emil"})
    CHECK(held(r.out, condition));
}

TEST_CASE("reference scenarios: wake-up (GoTo's tracker deployed, repaired on one camera)",
          "[integration][scenario]") {
  checkWakeUp(run(
      {"run", scenario("wake-up"), "--speed", kWakeSpeed, "--trace", "", "--picture", ""}, 280s));
}

TEST_CASE("reference scenarios: wake-up survives the living room's camera frozen for a while",
          "[fault][scenario]") {
  const Run r = run({"run", scenario("wake-up"), "--speed", kWakeSpeed, "--trace", "", "--picture",
                     "", "--inject", "stop camera-living-2 at 24 for 8"},
                    280s);
  CHECK_THAT(r.out, Contains("FAULT: stopped with SIGSTOP for 8.0 s"));
  CHECK_THAT(r.out, Contains("resumed with SIGCONT"));
  checkWakeUp(r);
}

void checkVacuumParcel(const Run& r) {
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK_THAT(r.out, Contains("the home's plan: Clean(vacuum, living-room)"));
  CHECK_THAT(r.out, Contains("the parcel's node: it weighs 2500 g"));
  CHECK_THAT(r.out, Contains("vacuum           configuration: mi-position now reads "
                             "tracker.position.vacuum"));
  CHECK_THAT(r.out, Contains("vacuum           configuration: mi-weight now reads parcel.Weight"));
  // The repair: the spare tracker, with the time it took since the kill.
  CHECK(std::regex_search(r.out, std::regex("vacuum +configuration: mi-position now reads "
                                            "tracker-2\\.position\\.vacuum \\([0-9.]+ s after "
                                            "kill tracker at 60\\)")));
  for (const char* condition :
       {"the cleaner's position comes from the tracker", "the parcel's weight reaches the cleaner",
        "the cleaner cleans with fresh positions", "a new configuration after the tracker died",
        "the spare tracker delivers the cleaner's position",
        "the cleaner cleans with fresh positions again",
        "the cleaner covers its room (at least 20 of its 38 lane ends)",
        "the cleaner finishes its room", "the home's task completes"})
    CHECK(held(r.out, condition));
}

TEST_CASE("reference scenarios: vacuum-parcel (the weight, the tracker killed and replaced)",
          "[integration][scenario]") {
  checkVacuumParcel(run(
      {"run", scenario("vacuum-parcel"), "--speed", kVacuumSpeed, "--trace", "", "--picture", ""},
      280s));
}

TEST_CASE("reference scenarios: vacuum-parcel survives a camera frozen for a while",
          "[fault][scenario]") {
  const Run r = run({"run", scenario("vacuum-parcel"), "--speed", kVacuumSpeed, "--trace", "",
                     "--picture", "", "--inject", "stop camera-living-1 at 30 for 8"},
                    280s);
  CHECK_THAT(r.out, Contains("FAULT: stopped with SIGSTOP for 8.0 s"));
  checkVacuumParcel(r);
}
