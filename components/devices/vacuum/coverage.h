// The vacuum cleaner's pure parts: a coverage path for a room (boustrophedon
// lanes across the room, one robot diameter apart, cut where the inflated map
// is lethal), and the decision to push an obstacle or go around it from its
// weight (javaspace-peis-middleware.txt §2: "the cleaner needs to know its
// properties (e.g., weight …) in order to decide weather it can push it away
// or not").
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "costmap.h"

namespace peis::devices {

using nav::Point2;

// A polygon from `room.<name>` = "X1 Y1 X2 Y2 …"; nothing when malformed.
std::optional<std::vector<Point2>> parsePolygon(std::string_view text);
bool insidePolygon(const std::vector<Point2>& polygon, Point2 p);

// Lane ends in driving order: lanes along x every `spacing` metres in y,
// each split into the runs of non-lethal cells inside the room, alternating
// direction lane by lane.
std::vector<Point2> coverageWaypoints(const nav::Costmap& costmap, const std::vector<Point2>& room,
                                      double spacing);

struct ObstacleDecision {
  bool push = false;
  std::string reason;  // "push: 800 g <= 1000 g", "avoid: 2500 g > 1000 g", "avoid: weight unknown"
};
ObstacleDecision decideObstacle(std::optional<long> grams, double pushLimitKg);

}  // namespace peis::devices
