// Random model generators (random_models.h).
#include "random_models.h"

#include <algorithm>
#include <string>

namespace peis::meta::testing {
namespace {

int uniform(std::mt19937& rng, int lo, int hi) {
  return std::uniform_int_distribution<int>(lo, hi)(rng);
}
bool chance(std::mt19937& rng, double p) { return std::bernoulli_distribution(p)(rng); }

Port port(std::string name, std::string type, std::string key = "") {
  return Port{std::move(name), Term::parse(type)->toString(), std::move(key)};
}

PeisInfo& peisNamed(Model& m, const std::string& name, int id, bool radio = false) {
  m.peis.push_back(PeisInfo{id, name, true, radio, {Descriptor{"c", {}}}});
  return m.peis.back();
}

}  // namespace

Problem smallRandom(std::mt19937& rng) {
  Problem p;
  auto& m = p.model;
  const int peisCount = uniform(rng, 2, 3);
  for (int i = 0; i < peisCount; ++i) {
    peisNamed(m, "p" + std::to_string(i), i + 1, i == 2 && chance(rng, 0.5));
  }
  if (chance(rng, 0.1)) m.peis[uniform(rng, 0, peisCount - 1)].alive = false;
  const char* robots[] = {"r1", "r2"};
  const char* cams[] = {"c1", "c2"};
  for (auto r : robots) {
    for (auto c : cams) {
      if (chance(rng, 0.6))
        m.facts.push_back({*Term::parse(std::string("sees(") + r + "," + c + ")"), ""});
    }
  }
  const int count = uniform(rng, 2, 7);
  for (int k = 0; k < count; ++k) {
    Functionality f;
    f.name = "f" + std::to_string(k);
    f.cost = uniform(rng, 0, 6) * 0.5;
    const auto r = std::string(robots[uniform(rng, 0, 1)]);
    const auto c = std::string(cams[uniform(rng, 0, 1)]);
    // Sometimes two functionalities write one key (they then exclude each other).
    const std::string suffix = chance(rng, 0.8) ? "-" + std::to_string(k) : "";
    const std::string in = chance(rng, 0.8) ? "mi-f" + std::to_string(k) + "-" : "mi-";
    switch (uniform(rng, 0, 6)) {
      case 0:  // camera
        f.outputs = {port("img", "img(" + c + ")", "img-" + c + suffix)};
        break;
      case 1:  // tracker, one camera
        f.inputs = {port("in", "img(?c)", in + "in.?c")};
        f.outputs = {port("pos", "pos(?r)", "pos" + suffix + ".?r")};
        f.preconditions = {"sees(?r,?c)"};
        break;
      case 2:  // tracker, two different cameras
        f.inputs = {port("a", "img(?a)", in + "a.?a"), port("b", "img(?b)", in + "b.?b")};
        f.outputs = {port("pos", "pos(?r)", "pos" + suffix + ".?r")};
        f.preconditions = {"sees(?r,?a)", "sees(?r,?b)", "?a != ?b"};
        break;
      case 3:  // odometry, maybe needing the map (a cycle with the mapper)
        f.outputs = {port("pos", "pos(" + r + ")", "odo" + suffix)};
        if (chance(rng, 0.5)) f.inputs = {port("map", "map", in + "map")};
        break;
      case 4:  // mapper
        f.inputs = {port("pos", "pos(" + r + ")", in + "pos")};
        f.outputs = {port("map", "map", "map" + suffix)};
        break;
      case 5:  // navigation for a robot
        f.inputs = {port("pos", "pos(?r)", in + "pos"), port("map", "map", in + "map")};
        f.outputs = {port("nav", "nav(?r)", "nav" + suffix + ".?r")};
        f.preconditions = {"robot(?r)"};
        break;
      default:  // a camera that also produces the map
        f.outputs = {port("img", "img(" + c + ")", "img-" + c + suffix),
                     port("map", "map", "map2" + suffix)};
        break;
    }
    m.peis[uniform(rng, 0, peisCount - 1)].components[0].functionalities.push_back(f);
  }
  m.facts.push_back({*Term::parse("robot(r1)"), ""});
  if (chance(rng, 0.3)) m.linkCosts = {0.2, 1.5, 3.0};
  const char* targets[] = {"pos(r1)", "pos(r2)", "nav(r1)", "map", "img(c1)", "nav(r2)"};
  const int goals = uniform(rng, 1, 3);
  for (int g = 0; g < goals; ++g) {
    InformationGoal goal;
    goal.information = *Term::parse(targets[uniform(rng, 0, 5)]);
    if (chance(rng, 0.8)) {
      goal.consumerPeis = m.peis[uniform(rng, 0, peisCount - 1)].name;
      goal.consumerKey = "mi-g" + std::to_string(g);
    }
    p.goals.information.push_back(goal);
  }
  if (chance(rng, 0.1))
    p.goals.constraints.avoidPeis.push_back("p" + std::to_string(uniform(rng, 0, peisCount - 1)));
  if (chance(rng, 0.1)) {
    p.goals.constraints.prefer.push_back(
        *InstanceSelector::parse("p" + std::to_string(uniform(rng, 0, peisCount - 1)) + "/c/f" +
                                     std::to_string(uniform(rng, 0, count - 1)),
                                 nullptr));
  }
  if (chance(rng, 0.1)) {
    p.goals.constraints.avoid.push_back(
        *InstanceSelector::parse("*/c/f" + std::to_string(uniform(rng, 0, count - 1)), nullptr));
  }
  if (chance(rng, 0.1))
    m.failed.push_back(
        *InstanceSelector::parse("*/c/f" + std::to_string(uniform(rng, 0, count - 1)), nullptr));
  return p;
}

Problem smallShared(std::mt19937& rng) {
  Problem p;
  auto& m = p.model;
  const int peisCount = uniform(rng, 2, 4);
  for (int i = 0; i < peisCount; ++i) {
    peisNamed(m, "q" + std::to_string(i), i + 1, i > 0 && chance(rng, 0.4));
  }
  if (chance(rng, 0.5)) m.linkCosts = {chance(rng, 0.5) ? 0.0 : 0.5, 1, uniform(rng, 2, 4) * 1.0};
  // Fan-out models (one type on top, asked for by many consumers) are where
  // using two producers of one thing pays off; else 2-3 layers of 1-3 types.
  const bool fanOut = chance(rng, 0.4);
  const int layers = fanOut ? 2 : uniform(rng, 2, 3);
  std::vector<std::vector<std::string>> types(layers);
  int made = 0;
  for (int layer = 0; layer < layers && made < 9; ++layer) {
    // Usually one type on top, so that several goals ask for it.
    const int count = layer + 1 == layers ? (fanOut || chance(rng, 0.7) ? 1 : 2)
                                          : uniform(rng, 1, fanOut ? 2 : 3);
    for (int t = 0; t < count && made < 9; ++t) {
      const auto type = std::string(1, static_cast<char>('a' + layer)) + std::to_string(t);
      types[layer].push_back(type);
      const int producers = fanOut && layer + 1 == layers ? uniform(rng, 2, 4) : uniform(rng, 1, 3);
      for (int k = 0; k < producers && made < 9; ++k, ++made) {
        Functionality f;
        f.name = "f" + std::to_string(made);
        f.cost = uniform(rng, 0, 8) * 0.5;
        // Now and then two producers of one PEIS write one key (then only one runs).
        const std::string key = chance(rng, 0.1) ? "out" : "out" + std::to_string(made);
        f.outputs = {port("out", type, key)};
        if (layer > 0) {
          const auto& below = types[layer - 1];
          const int inputs = uniform(rng, 1, std::min<int>(2, static_cast<int>(below.size())));
          std::vector<std::string> used;
          for (int i = 0; i < inputs; ++i) {
            const auto& in = below[uniform(rng, 0, static_cast<int>(below.size()) - 1)];
            if (std::find(used.begin(), used.end(), in) != used.end()) continue;
            used.push_back(in);
            f.inputs.push_back(port("in" + std::to_string(i), in));
          }
        }
        m.peis[uniform(rng, 0, peisCount - 1)].components[0].functionalities.push_back(f);
      }
    }
  }
  // Goals on the upper layers, most of them delivered to a consumer.
  const int goals = fanOut ? uniform(rng, 3, 7) : uniform(rng, 1, 5);
  for (int g = 0; g < goals; ++g) {
    const int layer = std::max(0, layers - 1 - (!fanOut && chance(rng, 0.3) ? 1 : 0));
    const auto& pool = types[layer].empty() ? types[0] : types[layer];
    InformationGoal goal;
    goal.information = *Term::parse(pool[uniform(rng, 0, static_cast<int>(pool.size()) - 1)]);
    if (chance(rng, 0.85)) {
      goal.consumerPeis = m.peis[uniform(rng, 0, peisCount - 1)].name;
      goal.consumerKey = "mi-g" + std::to_string(g);
    }
    p.goals.information.push_back(goal);
  }
  if (chance(rng, 0.05)) m.peis[uniform(rng, 1, peisCount - 1)].alive = false;
  if (chance(rng, 0.1)) {
    p.goals.constraints.prefer.push_back(
        *InstanceSelector::parse("*/c/f" + std::to_string(uniform(rng, 0, made - 1)), nullptr));
  }
  return p;
}

Problem sensing(std::mt19937& rng, int functionalities) {
  Problem p;
  auto& m = p.model;
  constexpr int kSensorKinds = 8, kConcepts = 10;
  const int perRoom = 12 + kConcepts * 3;
  const int rooms = std::max(1, functionalities / perRoom);
  int id = 1;
  // PCs that host the inferences, one per 5 rooms.
  const int pcs = std::max(1, rooms / 5);
  for (int i = 0; i < pcs; ++i) peisNamed(m, "pc" + std::to_string(i), id++);
  int made = 0;
  for (int room = 0; room < rooms; ++room) {
    const auto r = "room" + std::to_string(room);
    m.facts.push_back({*Term::parse("room(" + r + ")"), ""});
    for (int k = 0; k < kSensorKinds; ++k) {
      const int copies = chance(rng, 0.5) ? 2 : 1;
      for (int c = 0; c < copies && made < functionalities; ++c, ++made) {
        auto& node = peisNamed(
            m, "s" + std::to_string(room) + "-" + std::to_string(k) + "-" + std::to_string(c), id++,
            chance(rng, 0.7));
        Functionality f;
        f.name = "sense";
        f.cost = uniform(rng, 1, 3);
        f.outputs = {port("value", "sensor" + std::to_string(k) + "(" + r + ")")};
        node.components[0].functionalities.push_back(f);
      }
    }
  }
  // Inferences with a room variable: concept j from 1-5 sensors or lower concepts.
  for (int j = 0; j < kConcepts; ++j) {
    const int alternatives = uniform(rng, 2, 4);
    for (int a = 0; a < alternatives; ++a) {
      Functionality f;
      f.name = "infer" + std::to_string(j) + "-" + std::to_string(a);
      f.cost = uniform(rng, 1, 10);
      f.preconditions = {"room(?r)"};
      f.outputs = {port("c" + std::to_string(j), "concept" + std::to_string(j) + "(?r)")};
      const int inputs = uniform(rng, 1, 5);
      std::vector<std::string> used;
      for (int i = 0; i < inputs; ++i) {
        const bool lower = j > 0 && chance(rng, 0.3);
        const auto type =
            lower ? "concept" + std::to_string(uniform(rng, 0, j - 1)) + "(?r)"
                  : "sensor" + std::to_string(uniform(rng, 0, kSensorKinds - 1)) + "(?r)";
        if (std::find(used.begin(), used.end(), type) != used.end()) continue;
        used.push_back(type);
        f.inputs.push_back(
            port("in" + std::to_string(i), type, "mi-" + f.name + "-" + std::to_string(i) + ".?r"));
      }
      // Each inference runs on one PC, for every room it is asked about.
      m.peis[uniform(rng, 0, pcs - 1)].components[0].functionalities.push_back(f);
    }
  }
  const int goals = uniform(rng, 1, 3);
  for (int g = 0; g < goals; ++g) {
    InformationGoal goal;
    goal.information = *Term::parse("concept" + std::to_string(uniform(rng, 0, kConcepts - 1)) +
                                    "(room" + std::to_string(uniform(rng, 0, rooms - 1)) + ")");
    goal.consumerPeis = m.peis[uniform(rng, 0, pcs - 1)].name;
    goal.consumerKey = "mi-goal" + std::to_string(g);
    p.goals.information.push_back(goal);
  }
  return p;
}

Problem layered(std::mt19937& rng, int functionalities, int goalCount) {
  Problem p;
  auto& m = p.model;
  constexpr int kLayers = 5;
  const int typesPerLayer = std::max(1, functionalities / (kLayers * 2));
  const int peisCount = std::max(2, functionalities / 20);
  for (int i = 0; i < peisCount; ++i)
    peisNamed(m, "n" + std::to_string(i), i + 1, chance(rng, 0.1));
  auto typeName = [](int layer, int t) {
    return "t" + std::to_string(layer) + "_" + std::to_string(t);
  };
  int made = 0;
  for (int layer = 0; layer < kLayers; ++layer) {
    for (int t = 0; t < typesPerLayer; ++t) {
      const int producers = uniform(rng, 1, 3);
      for (int k = 0; k < producers; ++k, ++made) {
        Functionality f;
        f.name = "f" + std::to_string(made);
        f.cost = uniform(rng, 1, 10);
        f.outputs = {port("out", typeName(layer, t), "out-" + std::to_string(made))};
        if (layer > 0) {
          const int inputs = uniform(rng, 1, 3);
          std::vector<int> used;
          for (int i = 0; i < inputs; ++i) {
            // Inputs near the type's own index: neighbouring types share producers.
            const int u = std::clamp(t + uniform(rng, -3, 3), 0, typesPerLayer - 1);
            if (std::find(used.begin(), used.end(), u) != used.end()) continue;
            used.push_back(u);
            f.inputs.push_back(port("in" + std::to_string(i), typeName(layer - 1, u),
                                    "mi-" + f.name + "-" + std::to_string(i)));
          }
        }
        m.peis[uniform(rng, 0, peisCount - 1)].components[0].functionalities.push_back(f);
      }
    }
  }
  const int goals = goalCount > 0 ? goalCount : uniform(rng, 1, 20);
  const int center = uniform(rng, 0, typesPerLayer - 1);
  for (int g = 0; g < goals; ++g) {
    InformationGoal goal;
    const int t = std::clamp(center + uniform(rng, -6, 6), 0, typesPerLayer - 1);
    goal.information = *Term::parse(typeName(kLayers - 1, t));
    goal.consumerPeis = m.peis[uniform(rng, 0, peisCount - 1)].name;
    goal.consumerKey = "mi-goal" + std::to_string(g);
    p.goals.information.push_back(goal);
  }
  return p;
}

}  // namespace peis::meta::testing
