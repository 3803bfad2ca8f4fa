// The tracker's functionality descriptor; see tracker_descriptor.h.
#include "tracker_descriptor.h"

#include <cctype>

namespace peis::tracking {

std::string plannerName(const std::string& target) {
  std::string out = target;
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

Descriptor trackerDescriptor(const Descriptor& base, int cameras,
                             const std::vector<Target>& targets, std::optional<double> cost) {
  Descriptor d = base;
  auto& f = d.functionalities.at(0);
  f.inputs.clear();
  f.preconditions.clear();
  for (int k = 1; k <= cameras; ++k) {
    const std::string n = std::to_string(k);
    f.inputs.push_back({"camera" + n, "image(?c" + n + ")", "mi-camera" + n});
    for (int j = 1; j < k; ++j) f.preconditions.push_back("?c" + std::to_string(j) + " != ?c" + n);
  }
  f.outputs.clear();
  for (const auto& t : targets) {
    const std::string robot = plannerName(t.name);
    f.outputs.push_back({"position-" + robot, "position(" + robot + ")", "position." + t.name});
  }
  if (cost) f.cost = *cost;
  if (cameras >= 2) {
    // With one camera: the ground-plane intersection, a larger covariance
    // (the tracker copes with a robot only one camera sees); dearer.
    Functionality one = f;
    one.name = f.name + "-one-camera";
    one.description =
        "positions of the robots' hats seen by one ceiling camera (ground-plane "
        "intersection, larger covariance)";
    one.inputs.resize(1);
    one.preconditions.clear();
    one.cost = 2 * f.cost;
    d.functionalities.push_back(one);
  }
  // Read back: a target whose name is no term argument is an error here.
  return Descriptor::fromYaml(d.toYaml(), "the tracker's descriptor");
}

}  // namespace peis::tracking
