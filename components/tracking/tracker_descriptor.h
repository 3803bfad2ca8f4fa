// The tracker's functionality descriptor for the configuration planner:
// the template (tracking.yaml) completed with the inputs it really has
// (--cameras N: camera1..cameraN, each `image(?cK)` through mi-cameraK,
// pairwise different cameras) and one output per robot it follows
// (`position(pippi)` written to `position.Pippi`: the target's name in lower
// case is the robot's name in the task domains and its PEIS name). With two
// cameras or more a second functionality, `<name>-one-camera`, needs one
// image only and costs twice as much: what the tracker does when only one
// camera sees a robot, for a configuration when the other cameras are gone.
// Pure.
#pragma once

#include <optional>
#include <vector>

#include "peis/descriptor.h"
#include "tracking/targets.h"

namespace peis::tracking {

// `cost`, when given, replaces the template's (a spare tracker declared dearer).
Descriptor trackerDescriptor(const Descriptor& base, int cameras,
                             const std::vector<Target>& targets,
                             std::optional<double> cost = std::nullopt);

// The planner's name of a target: its name in lower case.
std::string plannerName(const std::string& target);

}  // namespace peis::tracking
