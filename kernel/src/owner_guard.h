// OwnerGuard: what an owner refuses of other PEIS. Every remote write and
// every subscription of this PEIS's tuples passes here, which makes the
// owner the one place these rules cannot be bypassed (docs/security.md):
//   - the kernel's own kernel.* tuples are written by this PEIS's kernel
//     only; of them, only kernel.do-quit takes a remote set (and, in a
//     secured ecology, kernel.policy, from the policy's administrators);
//   - in a secured ecology, the policy (security/policy.h) says who may
//     set, append to and delete which keys, and which of its subscriptions
//     a subscriber is sent (ReadAccess);
//   - a remote writer keeps within its quota of keys and bytes
//     (RemoteQuota, Options::limits), counted per principal when secured.
// A refused write changes nothing and is answered with the error; every
// refusal is counted and described in the kernel.denied tuple. Called with
// the Kernel's lock held, as Replication is.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "net/wire.h"
#include "peis/error.h"
#include "peis/kernel.h"
#include "remote_quota.h"
#include "security/identity.h"
#include "security/policy.h"
#include "tuple_space.h"

namespace peis {

class OwnerGuard {
 public:
  explicit OwnerGuard(const Limits& limits);

  // Who wrote, as the quota tells writers apart: the PEIS id in decimal by
  // default (an open ecology cannot tell more).
  using WriterName = std::function<std::string(PeisId)>;
  void setWriterName(WriterName name) { writerName_ = std::move(name); }
  // A secured ecology: the identities PEIS proved, and the policy.
  using Identities = std::function<const security::Identity*(PeisId)>;
  void secure(Identities identities, security::Policy policy);
  bool secured() const { return policy_ != nullptr; }
  const security::Policy* policy() const { return policy_.get(); }

  // Whether PEIS `source` may make `write` to own tuple `current` (null:
  // absent); the error to answer with if not (counted and described).
  std::optional<Error> checkWrite(PeisId self, PeisId source, const wire::Write& write,
                                  const Tuple* current);
  // Every change and deletion of an own tuple (the quota's bookkeeping; a
  // new kernel.policy is adopted). Inline for the common case: an open
  // PEIS's own write of a key no remote writer holds costs one test.
  void onOwnEvent(PeisId self, EventKind kind, const Tuple& tuple) {
    if (!policy_ && tuple.creator == self && quota_.empty()) return;
    ownEvent(self, kind, tuple);
  }

  // Which own tuples a subscriber is sent; null: all of them.
  class ReadAccess {
   public:
    ReadAccess(std::shared_ptr<const security::Policy> policy, security::Subject who)
        : policy_(std::move(policy)), who_(std::move(who)) {}
    bool allows(std::string_view key) const {
      return policy_ && policy_->allows(who_, security::Policy::Op::Read, key);
    }

   private:
    std::shared_ptr<const security::Policy> policy_;  // null: nobody proved to be it
    security::Subject who_;
  };
  std::shared_ptr<const ReadAccess> readAccess(PeisId subscriber) const;
  // A subscription was sent less than it matched (counted and described).
  void subscriptionFiltered(PeisId self, PeisId subscriber, std::string_view pattern);

  // The policy changed (a new kernel.policy) since last asked.
  bool takePolicyChanged() { return std::exchange(policyChanged_, false); }
  // Why a PEIS that proved `identity` is refused (its credentials revoked).
  std::optional<std::string> refusal(const security::Identity& identity) const;

  AccessStats stats() const { return stats_; }
  // The text of kernel.denied when it changed since last taken.
  std::optional<std::string> takeDeniedText();

 private:
  void ownEvent(PeisId self, EventKind kind, const Tuple& tuple);
  Error deny(std::uint64_t& counter, ErrorCode code, std::string message);
  std::string writer(PeisId id) const;
  std::optional<security::Subject> subject(PeisId id) const;
  std::string describe(PeisId id) const;

  RemoteQuota quota_;
  WriterName writerName_;
  Identities identities_;
  std::shared_ptr<const security::Policy> policy_;
  bool policyChanged_ = false;
  AccessStats stats_;
  std::string lastDenial_;
  bool deniedChanged_ = false;
};

}  // namespace peis
