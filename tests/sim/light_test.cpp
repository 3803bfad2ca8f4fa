// Unit tests of the light model (sim/world/light_model.h): the inverse
// square law of a lamp, the blind's attenuation of daylight, walls that
// block light, and the floor maps against the exact model.
#include <catch2/catch.hpp>
#include <cmath>

#include "sim/world/light_model.h"
#include "test_worlds.h"

using peis::sim::LightModel;
using peis::sim::LightState;
using peis::sim::Vec2;

TEST_CASE("a lamp lights a point by I cos(theta) / d^2 at its level", "[unit]") {
  const auto world = peis::sim::parseWorld(
      peis::test::boxWorld(
          "", "lamps:\n  - {name: lamp, position: [1, 1.5], height: 2, max_cd: 100}\n"),
      "lamp.yaml");
  const LightModel light(world);
  LightState state = peis::sim::initialLightState(world);
  CHECK(light.illuminance(state, {1, 1.5}, 0) == Approx(0.0));  // level 0, ambient 0
  CHECK(light.directLampTerm(0, {1, 1.5}, 0) == Approx(100.0 / 4));
  CHECK(light.directLampTerm(0, {2, 1.5}, 0) == Approx(100.0 * (2 / std::sqrt(5.0)) / 5));
  CHECK(light.directLampTerm(0, {1, 1.5}, 3) == Approx(0.0));  // above the lamp
  // Bounced light: half the mean direct light on the room's floor, everywhere in it.
  const double bounced = light.bouncedLampTerm(0, {1, 1.5});
  CHECK(bounced > 0);
  CHECK(bounced < 0.5 * 100.0 / 4);
  CHECK(light.bouncedLampTerm(0, {3.9, 0.2}) == Approx(bounced));
  state.lampLevel[0] = 100;
  CHECK(light.illuminance(state, {2, 1.5}, 0) ==
        Approx(100.0 * (2 / std::sqrt(5.0)) / 5 + bounced));
  state.lampLevel[0] = 50;
  CHECK(light.illuminance(state, {2, 1.5}, 0) ==
        Approx(0.5 * (100.0 * (2 / std::sqrt(5.0)) / 5 + bounced)));
}

TEST_CASE("the blind attenuates the daylight on the plant and the lamp lights the sofa", "[unit]") {
  const auto world = peis::sim::loadWorldFile(peis::test::peisHomePath());
  const LightModel light(world);
  LightState state = peis::sim::initialLightState(world);
  const Vec2 plant{0.3, 3.4}, sofa{2.6, 0.5};
  const double open = light.illuminance(state, plant, 0.6);
  state.blindTilt[0] = 50;
  const double half = light.illuminance(state, plant, 0.6);
  state.blindTilt[0] = 0;
  const double closed = light.illuminance(state, plant, 0.6);
  CHECK(open > 1000);
  CHECK(half < open);
  CHECK(closed < half);
  // Closing takes 95 % of this window's daylight away (the other windows'
  // light, through the doors, stays).
  CHECK(open - closed == Approx(world.daylightLux * 0.95 * light.windowTerm(0, plant, 0.6)));
  CHECK(closed < 0.1 * open);
  CHECK(peis::sim::blindOpening(50) == Approx(0.525));

  const double dark = light.illuminance(state, sofa, 0.8);
  state.lampLevel[0] = 100;
  const double lit = light.illuminance(state, sofa, 0.8);
  CHECK(lit - dark > 100);
}

TEST_CASE("walls block window and lamp light", "[unit]") {
  const auto world = peis::sim::loadWorldFile(peis::test::peisHomePath());
  const LightModel light(world);
  // The living-room window (index 0) does not reach behind the wall at x = 5.
  CHECK(light.directWindowTerm(0, {8.0, 3.0}, 0) == 0.0);
  CHECK(light.directWindowTerm(0, {2.0, 3.0}, 0) > 0.0);
  // Outside the home, a window gives no light.
  CHECK(light.directWindowTerm(0, {-0.5, 3.0}, 0) == 0.0);
  CHECK(light.windowTerm(0, {-0.5, 3.0}, 0) == 0.0);
  // The lamp does not light the bedroom behind the wall directly; a little
  // of its light bounces in through the door.
  CHECK(light.directLampTerm(0, {8.0, 3.0}, 0) == 0.0);
  CHECK(light.lampTerm(0, {8.0, 3.0}, 0) < 0.1 * light.lampTerm(0, {3.0, 1.5}, 0));
  CHECK(light.directLampTerm(0, {3.0, 1.5}, 0) > 0.0);
}

TEST_CASE("the floor maps agree with the exact model away from the windows", "[unit]") {
  const auto world = peis::sim::loadWorldFile(peis::test::peisHomePath());
  const LightModel light(world);
  LightState state = peis::sim::initialLightState(world);
  state.lampLevel[0] = 70;
  for (const Vec2 p :
       {Vec2{2.0, 2.0}, Vec2{3.3, 4.1}, Vec2{1.2, 1.7}, Vec2{6.5, 4.0}, Vec2{7.0, 1.0}}) {
    const double exact = light.illuminance(state, p, 0);
    const double mapped = light.floorIlluminance(state, p);
    CHECK(mapped == Approx(exact).epsilon(0.05));
  }
  CHECK(light.floorIlluminance(state, {-3, -3}) == Approx(world.ambientLux));
}
