// The hand-written configuration (see configurator_link.h).
#include "configurator_link.h"

#include <algorithm>
#include <memory>

#include "execution/exec_server.h"

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

void StaticConfigurator::withdraw(const std::vector<std::string>& needs) {
  for (const auto& need : needs) {
    const auto parts = parseNeed(need);
    if (!parts) continue;
    try {
      WriteOptions options;
      options.mimetype = kMetaMimetype;
      kernel_.setAsync(kernel_.resolveOwner(parts->consumer), parts->key, "", options);
    } catch (const Error&) {
      // The consumer is gone: nothing to withdraw.
    }
  }
}

GoalTupleConfigurator::GoalTupleConfigurator(Kernel& kernel, std::string goalKey,
                                             std::chrono::milliseconds deadline)
    : kernel_(kernel), goalKey_(std::move(goalKey)), deadline_(deadline) {}

void GoalTupleConfigurator::publish() {
  std::string text;
  for (const auto& need : posted_) text += need + "\n";
  kernel_.set(goalKey_, text);
}

void GoalTupleConfigurator::post(const std::vector<std::string>& needs, Done done) {
  std::vector<NeedParts> parts;
  for (const auto& need : needs) {
    // A need without a consumer (`image(astrid)`: the information must be
    // produced) is posted too; there is no meta tuple to watch for it.
    const auto p = parseNeed(need);
    if (p) parts.push_back(*p);
    if (!p && need.find('@') != std::string::npos)
      return done("'" + need + "' is not INFORMATION@PEIS.KEY");
    if (std::find(posted_.begin(), posted_.end(), need) == posted_.end()) posted_.push_back(need);
  }
  publish();
  // Deployed when every consumer's meta tuple points somewhere.
  struct Watch : std::enable_shared_from_this<Watch> {
    Kernel& kernel;
    std::vector<NeedParts> parts;
    Done done;
    std::chrono::steady_clock::time_point until;
    std::vector<bool> subscribed;
    Watch(Kernel& k, std::vector<NeedParts> p, Done d, std::chrono::steady_clock::time_point u)
        : kernel(k), parts(std::move(p)), done(std::move(d)), until(u), subscribed(parts.size()) {}
    void check() {
      bool all = true;
      for (std::size_t i = 0; i < parts.size(); ++i) {
        PeisId consumer = 0;
        try {
          consumer = kernel.resolveOwner(parts[i].consumer);
        } catch (const Error&) {
          all = false;
          continue;
        }
        if (!subscribed[i]) {
          kernel.subscribe(Pattern(parts[i].key, consumer));
          subscribed[i] = true;
        }
        const auto meta = kernel.get(consumer, parts[i].key);
        all = all && meta && !meta->data.empty();
      }
      if (all) return done(std::nullopt);
      if (std::chrono::steady_clock::now() >= until)
        return done("the configurator did not deploy it in time");
      kernel.after(std::chrono::milliseconds(100), [self = shared_from_this()] { self->check(); });
    }
  };
  auto watch = std::make_shared<Watch>(kernel_, std::move(parts), std::move(done),
                                       std::chrono::steady_clock::now() + deadline_);
  kernel_.post([watch] { watch->check(); });
}

void GoalTupleConfigurator::withdraw(const std::vector<std::string>& needs) {
  for (const auto& need : needs)
    posted_.erase(std::remove(posted_.begin(), posted_.end(), need), posted_.end());
  publish();
}

}  // namespace peis::executor
