// The configurations the three reference scenarios need, planned by the
// meta-level's configuration planner from the functionality descriptors of
// the components each scenario file runs (the descriptor files the programs
// publish, completed by their options as the programs complete them: the
// tracker's inputs, targets and cost, the photo camera's robot; the tiny
// nodes' descriptors from the tinybridge's seed) and the needs of the plan
// the task planner makes for the scenario's task. No processes: this is what
// the configurator will deploy, checked before any scenario runs.
#include <peis/meta/goals.h>
#include <peis/meta/model.h>
#include <peis/meta/planner.h>
#include <peis/meta/task.h>

#include <catch2/catch.hpp>
#include <set>

#include "node_descriptors.h"
#include "scenario_yaml.h"
#include "tracking/targets.h"
#include "tracking/tracker_descriptor.h"

using namespace peis;

namespace {

const std::string kSource = PEIS_SOURCE_DIR;

std::string here(const std::string& text, const std::string& dir) {
  std::string out = text;
  for (std::size_t at; (at = out.find("{here}")) != std::string::npos;) out.replace(at, 6, dir);
  return out;
}

std::optional<std::string> option(const scenario::PeisSpec& p, const std::string& name,
                                  const std::string& dir) {
  for (std::size_t i = 0; i + 1 < p.options.size(); ++i)
    if (p.options[i] == name) return here(p.options[i + 1], dir);
  return std::nullopt;
}

// The descriptor a scenario PEIS publishes, as its program builds it.
std::optional<Descriptor> descriptorOf(const scenario::PeisSpec& p, const std::string& dir) {
  const std::map<std::string, std::string> files = {
      {"peis-camera", "components/camera/camera.yaml"},
      {"peis-navigation", "components/navigation/navigation.yaml"},
      {"peis-vacuum", "components/devices/vacuum/vacuum.yaml"},
      {"peis-talk", "components/devices/talk/talk.yaml"},
      {"peis-executor", "components/executor/executor.yaml"},
      {"peis-photo-camera", "components/devices/photo/photo_camera.yaml"},
      {"peis-tracker", "components/tracking/tracking.yaml"},
  };
  const auto file = files.find(p.program);
  if (file == files.end()) return std::nullopt;
  Descriptor d = Descriptor::fromFile(kSource + "/" + file->second);
  if (p.program == "peis-tracker") {
    const auto cameras = option(p, "--cameras", dir);
    const auto cost = option(p, "--cost", dir);
    d = tracking::trackerDescriptor(d, cameras ? std::stoi(*cameras) : 2,
                                    tracking::loadTargets(*option(p, "--targets", dir)),
                                    cost ? std::optional<double>(std::stod(*cost)) : std::nullopt);
  }
  if (p.program == "peis-photo-camera") {
    if (const auto robot = option(p, "--robot", dir))
      for (auto& port : d.functionalities.at(0).outputs)
        if (const auto at = port.type.find("?self"); at != std::string::npos)
          port.type.replace(at, 5, *robot);
  }
  return d;
}

struct ScenarioModel {
  meta::Model model;
  std::vector<std::string> needs;  // of every step of the task's plan
  std::string plan;
};

ScenarioModel modelOf(const std::string& name) {
  const std::string dir = kSource + "/scenarios";
  const auto s = scenario::loadScenario(dir + "/" + name + ".yaml");
  const auto tiny = bridge::loadNodeDescriptors(kSource + "/bridge/keys.yaml");
  ScenarioModel out;
  int nextId = 100;
  for (const auto& p : s.peis) {
    meta::PeisInfo info;
    info.name = p.name;
    info.id = p.id ? static_cast<int>(*p.id) : nextId++;
    if (p.isTiny()) {
      info.radio = true;
      const auto d = tiny.find(static_cast<std::uint16_t>(*p.id));
      if (d != tiny.end()) info.components.push_back(d->second);
    } else if (const auto d = descriptorOf(p, dir)) {
      info.components.push_back(*d);
    }
    out.model.peis.push_back(info);
    if (p.program != "peis-executor") continue;
    // The executor's task: the scenario's goal for it, planned on its domain.
    const auto domain = meta::task::Domain::fromFile(*option(p, "--domain", dir));
    auto problem = meta::task::Problem::fromFile(*option(p, "--problem", dir));
    for (const auto& g : s.goals) {
      if (g.owner != p.name || g.key != "task") continue;
      problem.goal.clear();
      std::string rest = g.value;
      // `awake(johanna), at(pippi, sofa)`: literals split at top-level commas.
      int depth = 0;
      std::string current;
      for (const char c : rest + ",") {
        depth += c == '(' ? 1 : c == ')' ? -1 : 0;
        if (c == ',' && depth == 0) {
          const auto first = current.find_first_not_of(' ');
          problem.goal.push_back({*Term::parse(current.substr(first)), false});
          current.clear();
        } else {
          current += c;
        }
      }
    }
    const auto plan = meta::task::planTask(domain, problem);
    REQUIRE(plan.found);
    for (const auto& step : plan.steps) {
      out.plan += (out.plan.empty() ? "" : "; ") + step.toString();
      for (const auto& need : step.needs)
        if (std::find(out.needs.begin(), out.needs.end(), need) == out.needs.end())
          out.needs.push_back(need);
    }
  }
  return out;
}

std::set<std::string> linksOf(const meta::Configuration& c) {
  std::set<std::string> out;
  for (const auto& l : c.links) out.insert(l.toString());
  return out;
}

std::set<std::string> instancesOf(const meta::Configuration& c) {
  std::set<std::string> out;
  for (const auto& i : c.instances) out.insert(i.toString());
  return out;
}

}  // namespace

TEST_CASE("scenario configurations: wake-up's GoTo gets the tracker on the two cameras",
          "[unit][scenario]") {
  const auto s = modelOf("wake-up");
  CHECK(s.plan == "GoTo(pippi, bed); Talk(pippi, wakeup); GoTo(pippi, sofa)");
  REQUIRE(s.needs == std::vector<std::string>{"position(pippi)@pippi.mi-position"});
  meta::ConfigurationPlanner planner(s.model);
  const auto r = planner.plan(meta::Goals::fromArguments(s.needs));
  INFO(meta::formatText(r));
  REQUIRE(r.status == meta::PlanStatus::Optimal);
  const auto links = linksOf(r.configuration);
  CHECK(links.count("pippi.mi-position <- tracker.position.Pippi"));
  // The tracker's two inputs on the two cameras, one each.
  std::set<std::string> cameras;
  for (const auto& l : r.configuration.links)
    if (l.consumerPeis == "tracker") cameras.insert(l.producerPeis + "." + l.producerKey);
  CHECK(cameras == std::set<std::string>{"camera-bedroom.image", "camera-living-2.image"});
  CHECK(links.size() == 3);
  // The bedroom's camera gone (the scenario's fault stops it): the tracker
  // on the other camera alone, dearer.
  meta::InstanceSelector gone;
  gone.peis = "camera-bedroom";
  planner.setFailed(gone, true);
  const auto one = planner.plan(meta::Goals::fromArguments(s.needs));
  INFO(meta::formatText(one));
  REQUIRE(one.status == meta::PlanStatus::Optimal);
  CHECK(linksOf(one.configuration) ==
        std::set<std::string>{"pippi.mi-position <- tracker.position.Pippi",
                              "tracker.mi-camera1 <- camera-living-2.image"});
  CHECK(instancesOf(one.configuration)
            .count("tracker/tracker/camera-tracking-one-camera{?c1=camera-living-2}"));
  CHECK(one.configuration.cost > r.configuration.cost);
}

TEST_CASE(
    "scenario configurations: vacuum-parcel plans the tracker and the parcel's weight, "
    "and the spare tracker once the first has failed",
    "[unit][scenario]") {
  const auto s = modelOf("vacuum-parcel");
  CHECK(s.plan == "Clean(vacuum, living-room)");
  REQUIRE(s.needs == std::vector<std::string>{"position(vacuum)@vacuum.mi-position",
                                              "weight(parcel)@vacuum.mi-weight"});
  meta::ConfigurationPlanner planner(s.model);
  const auto goals = meta::Goals::fromArguments(s.needs);
  const auto r = planner.plan(goals);
  INFO(meta::formatText(r));
  REQUIRE(r.status == meta::PlanStatus::Optimal);
  auto links = linksOf(r.configuration);
  CHECK(links.count("vacuum.mi-position <- tracker.position.vacuum"));
  CHECK(links.count("vacuum.mi-weight <- parcel.Weight"));
  for (const auto& l : r.configuration.links)
    if (l.consumerKey == "mi-weight") CHECK(l.kind == meta::LinkKind::Radio);
  // The tracker is killed: the monitor marks its instance failed and plans
  // again — the spare tracker (declared dearer) on the same cameras.
  meta::InstanceSelector dead;
  dead.peis = "tracker";
  planner.setFailed(dead, true);
  meta::PlanOptions warm;
  warm.warmStart = &r.configuration;
  const auto repaired = planner.plan(goals, warm);
  INFO(meta::formatText(repaired));
  REQUIRE(repaired.status == meta::PlanStatus::Optimal);
  links = linksOf(repaired.configuration);
  CHECK(links.count("vacuum.mi-position <- tracker-2.position.vacuum"));
  CHECK(links.count("vacuum.mi-weight <- parcel.Weight"));
  CHECK(repaired.configuration.cost > r.configuration.cost);
}

TEST_CASE("scenario configurations: photo-sofa's GoTo gets the tracker, TakePhoto Astrid's camera",
          "[unit][scenario]") {
  const auto s = modelOf("photo-sofa");
  CHECK(s.plan == "GoTo(astrid, sofa); TakePhoto(astrid, sofa)");
  REQUIRE(s.needs ==
          std::vector<std::string>{"position(astrid)@astrid.mi-position", "image(astrid)"});
  meta::ConfigurationPlanner planner(s.model);
  for (const auto& need : s.needs) {
    const auto r = planner.plan(meta::Goals::fromArguments({need}));
    INFO(need << "\n" << meta::formatText(r));
    REQUIRE(r.status == meta::PlanStatus::Optimal);
    if (need == "image(astrid)") {
      CHECK(r.configuration.links.empty());
      CHECK(instancesOf(r.configuration) ==
            std::set<std::string>{"astrid-camera/photo-camera/photo"});
    } else {
      CHECK(linksOf(r.configuration).count("astrid.mi-position <- tracker.position.Astrid"));
    }
  }
}
