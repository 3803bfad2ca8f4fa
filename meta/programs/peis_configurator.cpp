// peis-configurator: the meta-level's long-running PEIS (introspection,
// goals, planning, deployment, monitoring and repair; see
// meta/monitor/configurator.h and docs/configuration.md).
#include <charconv>
#include <iostream>
#include <string>

#include "monitor/configurator.h"
#include "peis/error.h"
#include "peis/kernel.h"
#include "peis/log.h"
#include "peis/meta/model.h"
#include "peis/options.h"

namespace {

const char* kUsage = R"usage(Usage: peis-configurator [OPTIONS] [--peis-* options]

The meta-level's configurator: keeps a live model of the ecology (published as
model.live and model.yaml), plans the cheapest configuration for the goal
tuples any PEIS posts (config.goal.<label>, one goal per line), deploys it,
watches it and repairs it when a functionality fails. A component that a
launcher (peis init) declares but does not run is planned with too, and
started through its launcher when a configuration needs it. Events:
`peis config events --follow`. docs/configuration.md.

Options:
  --grace-ms N         a consumer waiting on an input this long gets its
                       producer replaced (default: the liveness period)
  --switch-margin F    switch to a cheaper configuration only when it is
                       cheaper by this fraction (default 0.2)
  --plan-time-ms N     time limit of one planning call (default 200)
  --retry-after-ms N   first retry of a functionality that did not deliver
                       (default 30000; doubles each time it fails again)
  --recover-hold-ms N  a failed part must look healthy this long before it is
                       used again (default: twice the grace period)
  --launch-wait-ms N   how long a component that a launcher (peis init) starts
                       for a configuration has to join (default 30000)
  --costs FILE         a model file whose link-costs and link-overrides apply
  --write-timeout-ms N deadline of one deployment write (default 2000)
  --lock-wait-ms N     how long to wait for a deployment lock that another
                       live deployer holds (default 5000)
  --help               this text
)usage";

long number(const std::string& option, const std::string& text, long low, long high) {
  long value = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size() || value < low || value > high)
    throw std::invalid_argument(option + " takes a whole number in " + std::to_string(low) + ".." +
                                std::to_string(high));
  return value;
}

}  // namespace

int main(int argc, char** argv) {
  peis::Options peisOptions;
  try {
    peisOptions = peis::Options::fromArgs(argc, argv);
  } catch (const peis::Error& e) {
    std::cerr << "peis-configurator: " << e.what() << "\n";
    return 2;
  }
  peis::meta::ConfiguratorOptions options;
  peisOptions.writeTimeout = std::chrono::milliseconds(2000);
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--help" || a == "-h") {
        std::cout << kUsage << "\n" << peis::Options::helpText();
        return 0;
      }
      if (i + 1 >= argc) throw std::invalid_argument("unknown option or missing value: " + a);
      const std::string v = argv[++i];
      if (a == "--grace-ms") {
        options.grace = std::chrono::milliseconds(number(a, v, 1, 3600000));
      } else if (a == "--switch-margin") {
        char* end = nullptr;
        const double margin = std::strtod(v.c_str(), &end);
        if (*end || !(margin >= 0) || margin >= 1)
          throw std::invalid_argument("--switch-margin takes a fraction in [0, 1)");
        options.switchMargin = margin;
      } else if (a == "--plan-time-ms") {
        options.planTimeLimit = std::chrono::milliseconds(number(a, v, 1, 600000));
      } else if (a == "--recover-hold-ms") {
        options.recoverHold = std::chrono::milliseconds(number(a, v, 1, 3600000));
      } else if (a == "--retry-after-ms") {
        options.retryAfter = std::chrono::milliseconds(number(a, v, 1, 86400000));
      } else if (a == "--write-timeout-ms") {
        peisOptions.writeTimeout = std::chrono::milliseconds(number(a, v, 1, 600000));
      } else if (a == "--lock-wait-ms") {
        options.deploy.lockWait = std::chrono::milliseconds(number(a, v, 0, 600000));
      } else if (a == "--launch-wait-ms") {
        options.launchWait = std::chrono::milliseconds(number(a, v, 1, 3600000));
      } else if (a == "--costs") {
        const auto model = peis::meta::Model::fromFile(v);
        options.costs = model.linkCosts;
        options.overrides = model.linkOverrides;
      } else {
        throw std::invalid_argument("unknown option " + a);
      }
    }
  } catch (const std::invalid_argument& e) {
    std::cerr << "peis-configurator: " << e.what() << " (see --help)\n";
    return 2;
  } catch (const peis::Error& e) {
    std::cerr << "peis-configurator: " << e.what() << "\n";
    return 2;
  }
  try {
    peis::Kernel kernel(peisOptions);
    peis::meta::Configurator configurator(kernel, options);
    const auto reason = kernel.run();
    peis::log::info(kernel.id(), "configurator: " + reason);
  } catch (const peis::Error& e) {
    std::cerr << "peis-configurator: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
