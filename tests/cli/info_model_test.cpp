// What `peis info` reads from a PEIS's tuples (kernel/tools/info_model.h),
// and which PEIS `peis ls` lists (lookup.h).
#include "info_model.h"

#include <catch2/catch.hpp>

#include "lookup.h"

using Catch::Matchers::Contains;
using peis::Tuple;

namespace {

Tuple tuple(peis::PeisId owner, std::string key, std::string data) {
  Tuple t;
  t.owner = owner;
  t.key = std::move(key);
  t.data = std::move(data);
  return t;
}

std::vector<Tuple> lampTuples() {
  return {
      tuple(12, "kernel.name", "lamp"),
      tuple(12, "kernel.hostname", "vm"),
      tuple(12, "kernel.started", "1000000"),
      tuple(12, "kernel.links", "11 13"),
      tuple(12, "kernel.subscribers", "13"),
      tuple(12, "component.name", "lamp"),
      tuple(12, "status", "waiting"),
      tuple(12, "cause.names", "position"),
      tuple(12, "mi-brightness", "11.brightness"),
      tuple(12, "mi-position", ""),
      tuple(12, "component.outputs", "level"),
      tuple(12, "light.reqState", "on"),
      tuple(12, "light.currState", "off"),
      tuple(12, "light.status", "busy"),
      tuple(12, "door.status", "open"),  // no currState: not an actuator
      tuple(11, "status", "running"),    // another PEIS's: ignored
  };
}

std::string nameOf(peis::PeisId id) { return id == 11 ? "sensor" : id == 13 ? "watcher" : ""; }

}  // namespace

TEST_CASE("info: the component, its inputs, outputs and actuators", "[unit][cli]") {
  const auto info =
      peis::cli::collectInfo(12, lampTuples(), peis::Timestamp(std::chrono::seconds(4)));
  CHECK(info.name == "lamp");
  CHECK(info.upSeconds == Approx(3.0));
  CHECK(info.links == std::vector<peis::PeisId>{11, 13});
  CHECK(info.subscribers == std::vector<peis::PeisId>{13});
  CHECK(info.component == "lamp");
  CHECK(info.status == "waiting");
  REQUIRE(info.inputs.size() == 2);
  CHECK(info.inputs[0].name == "brightness");
  CHECK(info.inputs[0].target == "11.brightness");
  CHECK(info.inputs[0].targetOwner == std::optional<peis::PeisId>(11));
  CHECK_FALSE(info.inputs[0].missing);
  CHECK(info.inputs[1].name == "position");
  CHECK(info.inputs[1].target.empty());
  CHECK(info.inputs[1].missing);
  CHECK(info.outputs == std::vector<std::string>{"level"});
  REQUIRE(info.actuators.size() == 1);
  CHECK(info.actuators[0].name == "light");
  CHECK(info.actuators[0].reqState == "on");
  CHECK(info.actuators[0].currState == "off");
  CHECK(info.actuators[0].status == "busy");

  const auto text = peis::cli::formatInfo(info, nameOf);
  CHECK_THAT(text, Contains("PEIS 12 'lamp' on vm"));
  CHECK_THAT(text, Contains("links        11 (sensor), 13 (watcher)"));
  CHECK_THAT(text, Contains("subscribers  13 (watcher)"));
  CHECK_THAT(text, Contains("component lamp: waiting (position)"));
  CHECK_THAT(text, Contains("brightness <- 11.brightness (sensor)\n"));
  CHECK_THAT(text, Contains("position <- (nowhere)  [missing or stale]"));
  CHECK_THAT(text, Contains("outputs level"));
  CHECK_THAT(text, Contains("light: reqState on, currState off, status busy"));

  const auto json = peis::cli::infoJson(info);
  CHECK_THAT(json, Contains("\"inputs\":[{\"name\":\"brightness\",\"target\":\"11.brightness\","
                            "\"missing\":false}"));
  CHECK_THAT(json, Contains("\"links\":[11,13]"));
}

TEST_CASE("info of a PEIS without a component", "[unit][cli]") {
  const auto info =
      peis::cli::collectInfo(5, {tuple(5, "kernel.name", "plain")}, peis::systemNow());
  CHECK(info.component.empty());
  CHECK(info.upSeconds < 0);
  CHECK_THAT(peis::cli::formatInfo(info, nameOf), Contains("no component"));
}

TEST_CASE("ls leaves itself and the tool PEIS out unless --all", "[unit][cli]") {
  std::vector<peis::PeerInfo> peers{
      {5, "self", 0, 1, true}, {7, "lamp", 1, 1, false}, {9, "peis-watch", 1, 1, true}};
  auto ids = [](const std::vector<peis::PeerInfo>& list) {
    std::vector<peis::PeisId> result;
    for (const auto& p : list) result.push_back(p.id);
    return result;
  };
  CHECK(ids(peis::cli::listedPeers(peers, 5, false)) == std::vector<peis::PeisId>{7});
  CHECK(ids(peis::cli::listedPeers(peers, 5, true)) == std::vector<peis::PeisId>{7, 9});
}
