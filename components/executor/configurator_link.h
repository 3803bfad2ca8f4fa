// How the executor gets the configuration a step needs, kept behind one small
// interface because the configurator (meta-level, branch meta-runtime) and
// its goal tuples are not there yet. `post` asks for the needs of a step and
// reports through `done` (no error = deployed); `withdraw` gives them back.
//
// StaticConfigurator is the hand-written configuration of the tiny paper's
// experiment ("the ecology configuration has been hand-coded"): a table
// INFORMATION -> producer PEIS.KEY; posting `position(pippi)@Pippi.mi-position`
// points Pippi's meta tuple mi-position at the producer (a remote write the
// consumer acknowledges), withdrawing empties it. A configurator-backed
// implementation replaces it once docs/configuration.md defines the goals.
#pragma once

#include <peis/kernel.h>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "plan_text.h"

namespace peis::executor {

class ConfiguratorLink {
 public:
  using Done = std::function<void(const std::optional<std::string>& error)>;
  virtual ~ConfiguratorLink() = default;
  // Runs on the kernel thread; `done` is called there, once.
  virtual void post(const std::vector<std::string>& needs, Done done) = 0;
  virtual void withdraw(const std::vector<std::string>& needs) = 0;
};

class StaticConfigurator : public ConfiguratorLink {
 public:
  // A consumer or producer PEIS not known yet is waited for up to `peerWait`.
  StaticConfigurator(Kernel& kernel, std::vector<StaticLink> links,
                     std::chrono::milliseconds peerWait = std::chrono::seconds(10));
  void post(const std::vector<std::string>& needs, Done done) override;
  void withdraw(const std::vector<std::string>& needs) override;

 private:
  Kernel& kernel_;
  std::map<std::string, StaticLink> links_;
  std::chrono::milliseconds peerWait_;
};

// Through the meta-level's configurator (branch meta-runtime,
// meta/monitor/goal_tuples.h): the needs being pursued are posted as the
// executor's own `config.goal.<name>` tuple, one goal per line, and withdrawn
// by rewriting it without them (empty when none is left). A post counts as
// deployed once every need's consumer meta tuple points somewhere (the
// configurator's deployment wrote it); it fails after `deadline`. A need
// without a consumer (`image(astrid)`: only produced) is posted and not
// waited for: no meta tuple says when it is.
class GoalTupleConfigurator : public ConfiguratorLink {
 public:
  GoalTupleConfigurator(Kernel& kernel, std::string goalKey,
                        std::chrono::milliseconds deadline = std::chrono::seconds(30));
  void post(const std::vector<std::string>& needs, Done done) override;
  void withdraw(const std::vector<std::string>& needs) override;

 private:
  void publish();
  Kernel& kernel_;
  std::string goalKey_;
  std::chrono::milliseconds deadline_;
  std::vector<std::string> posted_;
};

}  // namespace peis::executor
