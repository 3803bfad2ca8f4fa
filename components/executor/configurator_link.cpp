// The hand-written configuration (see configurator_link.h).
#include "configurator_link.h"

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

}  // namespace peis::executor
