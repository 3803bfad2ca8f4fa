// The hand-written configuration (see configurator_link.h).
#include "configurator_link.h"

#include <algorithm>
#include <memory>
#include <set>

#include "execution/exec_server.h"
#include "monitor/goal_tuples.h"

namespace peis::executor {

StaticConfigurator::StaticConfigurator(Kernel& kernel, std::vector<StaticLink> links,
                                       std::chrono::milliseconds peerWait)
    : kernel_(kernel), peerWait_(peerWait) {
  for (auto& link : links) links_[link.information] = std::move(link);
}

void StaticConfigurator::post(const std::vector<std::string>& needs, Done done) {
  struct Pending {
    std::size_t left;
    std::optional<std::string> error;
    Done done;
  };
  auto pending = std::make_shared<Pending>(Pending{needs.size(), std::nullopt, std::move(done)});
  auto finishOne = [pending](const std::optional<std::string>& error) {
    if (error && !pending->error) pending->error = error;
    if (--pending->left == 0) pending->done(pending->error);
  };
  if (needs.empty()) return pending->done(std::nullopt);
  for (const auto& need : needs) {
    const auto parts = parseNeed(need);
    if (!parts) {
      finishOne("'" + need + "' is not INFORMATION@PEIS.KEY");
      continue;
    }
    const auto link = links_.find(parts->information);
    if (link == links_.end()) {
      finishOne("no producer of " + parts->information + " in the static configuration (--link)");
      continue;
    }
    const StaticLink producer = link->second;
    const NeedParts consumer = *parts;
    exec::resolvePeer(
        kernel_, consumer.consumer, peerWait_,
        [this, consumer, producer, finishOne](std::optional<PeisId> consumerId) {
          if (!consumerId) return finishOne("no PEIS named '" + consumer.consumer + "' joined");
          exec::resolvePeer(
              kernel_, producer.producer, peerWait_,
              [this, consumer, producer, finishOne, consumerId](std::optional<PeisId> producerId) {
                if (!producerId)
                  return finishOne("no PEIS named '" + producer.producer + "' joined");
                WriteOptions options;
                options.mimetype = kMetaMimetype;
                kernel_.setAsync(
                    *consumerId, consumer.key, fullName(*producerId, producer.key), options,
                    [finishOne](const std::optional<Error>& error, std::uint64_t) {
                      finishOne(error ? std::optional<std::string>(error->what()) : std::nullopt);
                    });
              });
        });
  }
}

void StaticConfigurator::withdraw(const std::vector<std::string>& needs, Done done) {
  // `done` once every emptied meta tuple is acknowledged (a remote write is
  // sent again until it is, within the kernel's write timeout).
  auto left = std::make_shared<std::size_t>(1);
  auto finishOne = [left, done = std::move(done)](const std::optional<std::string>& error) {
    if (--*left == 0 && done) done(error);
  };
  for (const auto& need : needs) {
    const auto parts = parseNeed(need);
    if (!parts) continue;
    try {
      WriteOptions options;
      options.mimetype = kMetaMimetype;
      ++*left;
      kernel_.setAsync(
          kernel_.resolveOwner(parts->consumer), parts->key, "", options,
          [finishOne](const std::optional<Error>& error, std::uint64_t) {
            finishOne(error ? std::optional<std::string>(error->what()) : std::nullopt);
          });
    } catch (const Error&) {
      --*left;  // The consumer is gone: nothing to withdraw.
    }
  }
  finishOne(std::nullopt);
}

GoalTupleConfigurator::GoalTupleConfigurator(Kernel& kernel, std::string goalKey,
                                             std::chrono::milliseconds deadline)
    : kernel_(kernel), goalKey_(std::move(goalKey)), deadline_(deadline) {}

std::uint64_t GoalTupleConfigurator::publish() {
  return kernel_.set(goalKey_, meta::formatGoalTuple(posted_)).seqno;
}

void GoalTupleConfigurator::post(const std::vector<std::string>& needs, Done done) {
  std::vector<NeedParts> consumers;
  for (const auto& need : needs) {
    // A need without a consumer (`image(astrid)`: the information must be
    // produced) is posted too; the configurator's answer covers it.
    const auto parts = parseNeed(need);
    if (parts) consumers.push_back(*parts);
    if (!parts && need.find('@') != std::string::npos)
      return done("'" + need + "' is not INFORMATION@PEIS.KEY");
    if (std::find(posted_.begin(), posted_.end(), need) == posted_.end()) posted_.push_back(need);
  }
  if (!subscribed_) {
    kernel_.subscribe(Pattern(std::string(meta::kGoalStatusKey)));
    kernel_.subscribe(Pattern("config.configurator"));
    subscribed_ = true;
  }
  const auto seqno = publish();
  // Deployed when a configurator answers this seqno of the tuple (or a later
  // one). With no configurator in the ecology at all, when every consumer's
  // meta tuple points somewhere: a configuration made by hand (`peis meta`).
  struct Watch : std::enable_shared_from_this<Watch> {
    Kernel& kernel;
    std::string key;
    std::uint64_t seqno;
    std::vector<NeedParts> consumers;
    Done done;
    std::chrono::steady_clock::time_point until;
    std::string last = "no configurator answered";
    std::set<std::pair<PeisId, std::string>> followed;
    Watch(Kernel& k, std::string key, std::uint64_t s, std::vector<NeedParts> c, Done d,
          std::chrono::steady_clock::time_point u)
        : kernel(k),
          key(std::move(key)),
          seqno(s),
          consumers(std::move(c)),
          done(std::move(d)),
          until(u) {}
    bool configuratorAlive() const {
      const auto peers = kernel.peers();
      for (const auto& t : kernel.find(Pattern("config.configurator"))) {
        for (const auto& p : peers)
          if (p.id == t.owner && !t.data.empty()) return true;
      }
      return false;
    }
    bool pointedByHand() {
      for (const auto& c : consumers) {
        PeisId id = 0;
        try {
          id = kernel.resolveOwner(c.consumer);
        } catch (const Error&) {
          return false;
        }
        if (followed.insert({id, c.key}).second) kernel.subscribe(Pattern::exact(id, c.key));
        const auto meta = kernel.get(id, c.key);
        if (!meta || meta->data.empty()) return false;
      }
      return true;
    }
    void check() {
      for (const auto& t : kernel.find(Pattern(std::string(meta::kGoalStatusKey)))) {
        for (const auto& line : meta::parseGoalStatus(t.data)) {
          if (line.owner != kernel.id() || line.key != key || line.seqno < seqno) continue;
          switch (line.state) {
            case meta::GoalState::Deployed:
              return done(std::nullopt);
            case meta::GoalState::Infeasible:
            case meta::GoalState::Refused:
              return done(std::string("the configurator says ") + meta::toString(line.state) +
                          ": " + line.reason);
            case meta::GoalState::Pending:
              last = "pending: " + line.reason;
          }
        }
      }
      if (!configuratorAlive() && pointedByHand()) return done(std::nullopt);
      if (std::chrono::steady_clock::now() >= until)
        return done("the configurator did not deploy it in time (" + last + ")");
      kernel.after(std::chrono::milliseconds(20), [self = shared_from_this()] { self->check(); });
    }
  };
  auto watch =
      std::make_shared<Watch>(kernel_, goalKey_, seqno, std::move(consumers), std::move(done),
                              std::chrono::steady_clock::now() + deadline_);
  kernel_.post([watch] { watch->check(); });
}

void GoalTupleConfigurator::withdraw(const std::vector<std::string>& needs, Done done) {
  for (const auto& need : needs)
    posted_.erase(std::remove(posted_.begin(), posted_.end(), need), posted_.end());
  publish();  // an own tuple: the configurator follows it (or sees this PEIS leave)
  if (done) done(std::nullopt);
}

}  // namespace peis::executor
