// Path planning on the costmap: A* over the 8-connected grid (no corner
// cutting through lethal cells), octile-distance heuristic (admissible since
// every step costs at least its length), then the cell path is shortened to
// waypoints joined by straight lines that cross no lethal cell and come no
// nearer the walls than the A* path did.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "costmap.h"

namespace peis::nav {

enum class PlanFailure { None, StartOutsideMap, GoalOutsideMap, StartBlocked, GoalBlocked, NoPath };
// The cause as ExecStatus reports it: "no path", "goal blocked", …
const char* toString(PlanFailure failure);

struct PlannedPath {
  PlanFailure failure = PlanFailure::None;
  std::vector<Cell> cells;        // the A* path, start to goal
  std::vector<Point2> waypoints;  // start, the corners kept, goal (map coordinates)
  double cost = 0;                // A* cost in metres, weighted by the step factors
  double length = 0;              // length of the waypoint polyline, metres
  std::int64_t expanded = 0;      // cells taken off the open list
  bool found() const { return failure == PlanFailure::None; }
};

struct PlanOptions {
  // A start in a lethal cell (the robot pressed against a wall) may leave by
  // the nearest free cell within this distance.
  double startEscape = 0.5;
  // A goal in a lethal cell is moved to the nearest free cell within this
  // distance, or the plan fails with GoalBlocked.
  double goalTolerance = 0.05;
  bool shorten = true;
};

PlannedPath planPath(const Costmap& costmap, Point2 start, Point2 goal,
                     const PlanOptions& options = {});

// Whether the straight segment crosses only cells that are not lethal.
bool segmentFree(const Costmap& costmap, Point2 a, Point2 b);

}  // namespace peis::nav
