// Test helper for the meta-level's multi-process tests: an ecology of its own
// with synthetic components (peis-synthetic), configurators and peis-config
// commands as separate processes, and an observer Kernel in the test that
// reads their tuples. Every process gets the same liveness period.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "peis/kernel.h"
#include "peis/log.h"
#include "support/integration.h"
#include "support/process.h"
#include "support/wait_for.h"

namespace peis::test {

inline std::string descriptorPath(const std::string& name) {
  return std::string(PEIS_SOURCE_DIR) + "/tests/meta/descriptors/" + name;
}

struct MetaEcology {
  std::string ecology;
  std::chrono::milliseconds liveness;
  std::vector<std::unique_ptr<Process>> processes;
  std::unique_ptr<Kernel> observer;

  explicit MetaEcology(const std::string& tag,
                       std::chrono::milliseconds livenessPeriod = std::chrono::milliseconds(1000))
      : ecology(uniqueEcology(tag)), liveness(livenessPeriod) {
    Options options;
    options.ecology = ecology;
    options.name = "observer";
    options.liveness = liveness;
    // The observer's own links are noise next to a failure's report (a
    // report cut short would show only them): warnings, unless PEIS_LOG asks.
    if (!peis::log::levelFromEnvironment()) peis::log::setLevel(peis::log::Level::Warn);
    observer = std::make_unique<Kernel>(options);
  }

  Process::Environment environment() const {
    return {{"PEIS_LIVENESS_MS", std::to_string(liveness.count())}, {"PEIS_LOG", "info"}};
  }

  Process& start(const std::string& program, std::vector<std::string> args) {
    args.insert(args.begin(), program);
    args.push_back("--peis-ecology");
    args.push_back(ecology);
    processes.push_back(std::make_unique<Process>(args, environment()));
    return *processes.back();
  }

  // peis-synthetic as PEIS `name` with a descriptor of tests/meta/descriptors/.
  Process& synthetic(const std::string& name, const std::string& descriptor,
                     std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {
        "--peis-name", name, "--descriptor",   descriptorPath(descriptor),
        "--period-ms", "50", "--freshness-ms", "300"};
    args.insert(args.end(), extra.begin(), extra.end());
    return start(PEIS_SYNTHETIC_PATH, args);
  }

  Process& configurator(std::vector<std::string> extra = {}) {
    return start(PEIS_CONFIGURATOR_PATH, extra);
  }

  // Runs `peis-config ARGS…` to its end.
  CliResult config(std::vector<std::string> args,
                   std::chrono::milliseconds deadline = std::chrono::seconds(60)) {
    args.insert(args.begin(), PEIS_CONFIG_PATH);
    args.push_back("--peis-ecology");
    args.push_back(ecology);
    Process tool(args, environment());
    const auto status = tool.wait(deadline);
    INFO(tool.describe());
    REQUIRE(status.has_value());
    return CliResult{*status, tool.out(), tool.err()};
  }

  // Waits until a PEIS of that name is reachable; its id (the test fails otherwise).
  PeisId await(const std::string& name) {
    const auto id = observer->waitForPeer(name, std::chrono::seconds(30));
    INFO("PEIS " << name << " did not join\n" << describeAll());
    REQUIRE(id.has_value());
    return *id;
  }

  // Follows one tuple of another PEIS (the observer subscribes to it).
  void follow(PeisId owner, const std::string& keyPattern) {
    observer->subscribe(Pattern(keyPattern, owner));
  }

  std::string value(PeisId owner, const std::string& key) const {
    auto t = observer->get(owner, key);
    return t ? t->data : "<absent>";
  }
  std::uint64_t seqno(PeisId owner, const std::string& key) const {
    auto t = observer->get(owner, key);
    return t ? t->seqno : 0;
  }

  std::string describeAll() {
    std::string out;
    for (auto& p : processes) out += p->describe() + "\n";
    return out;
  }
};

}  // namespace peis::test
