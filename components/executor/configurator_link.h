// How the executor gets the configuration a step needs, behind one small
// interface: `post` asks for the needs of a step and reports through `done`
// (no error = deployed); `withdraw` gives them back and reports through
// `done` once every consumer has acknowledged (or is gone), so a program can
// leave without taking its withdrawal with it.
//
// StaticConfigurator is the hand-written configuration of the tiny paper's
// experiment ("the ecology configuration has been hand-coded"): a table
// INFORMATION -> producer PEIS.KEY; posting `position(pippi)@Pippi.mi-position`
// points Pippi's meta tuple mi-position at the producer (a remote write the
// consumer acknowledges), withdrawing empties it.
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
  virtual void withdraw(const std::vector<std::string>& needs, Done done) = 0;
};

class StaticConfigurator : public ConfiguratorLink {
 public:
  // A consumer or producer PEIS not known yet is waited for up to `peerWait`.
  StaticConfigurator(Kernel& kernel, std::vector<StaticLink> links,
                     std::chrono::milliseconds peerWait = std::chrono::seconds(10));
  void post(const std::vector<std::string>& needs, Done done) override;
  void withdraw(const std::vector<std::string>& needs, Done done) override;

 private:
  Kernel& kernel_;
  std::map<std::string, StaticLink> links_;
  std::chrono::milliseconds peerWait_;
};

// Through the meta-level's configurator (peis-configurator, goal tuples in
// meta/monitor/goal_tuples.h): the needs being pursued are posted as the
// executor's own `config.goal.<name>` tuple, one goal per line, and withdrawn
// by rewriting it without them (empty when none is left). A post counts as
// deployed when a configurator's `config.goal-status` says `deployed` for
// that tuple at (or after) the posted seqno; `infeasible` or `refused`
// fails it at once with the configurator's reason, and no answer by
// `deadline` fails it with the last state seen.
// A need without a consumer (`image(astrid)`: only produced) is posted too;
// the configurator's answer covers it like the others. With no configurator
// in the ecology at all (no alive PEIS has `config.configurator`), a post
// counts as deployed once every consumer's meta tuple points somewhere: a
// configuration made by hand (`peis meta`), as the scenario tests do.
class GoalTupleConfigurator : public ConfiguratorLink {
 public:
  GoalTupleConfigurator(Kernel& kernel, std::string goalKey,
                        std::chrono::milliseconds deadline = std::chrono::seconds(30));
  void post(const std::vector<std::string>& needs, Done done) override;
  void withdraw(const std::vector<std::string>& needs, Done done) override;

 private:
  std::uint64_t publish();
  Kernel& kernel_;
  std::string goalKey_;
  std::chrono::milliseconds deadline_;
  std::vector<std::string> posted_;
  bool subscribed_ = false;
};

}  // namespace peis::executor
