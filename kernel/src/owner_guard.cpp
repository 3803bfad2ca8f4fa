// OwnerGuard: the owner's refusals; see owner_guard.h.
#include "owner_guard.h"

#include "log.h"

namespace peis {

namespace {

bool isKernelKey(std::string_view key) { return key.rfind("kernel.", 0) == 0; }

security::Policy::Op opOf(wire::WriteOp op) {
  switch (op) {
    case wire::WriteOp::Set:
      return security::Policy::Op::Write;
    case wire::WriteOp::Append:
      return security::Policy::Op::Append;
    case wire::WriteOp::Erase:
      return security::Policy::Op::Delete;
  }
  return security::Policy::Op::Write;
}

}  // namespace

OwnerGuard::OwnerGuard(const Limits& limits)
    : quota_(RemoteQuota::Limits{limits.quotaKeys, limits.quotaBytes, limits.quotaTotalKeys,
                                 limits.quotaTotalBytes}) {}

void OwnerGuard::secure(Identities identities, security::Policy policy) {
  identities_ = std::move(identities);
  policy_ = std::make_shared<const security::Policy>(std::move(policy));
  // Quotas per principal: a group of PEIS sharing credentials shares one.
  writerName_ = [this](PeisId id) {
    const auto* identity = identities_ ? identities_(id) : nullptr;
    return identity ? "principal:" + identity->certificate.principal : std::to_string(id);
  };
}

std::string OwnerGuard::writer(PeisId id) const {
  return writerName_ ? writerName_(id) : std::to_string(id);
}

std::optional<security::Subject> OwnerGuard::subject(PeisId id) const {
  const auto* identity = identities_ ? identities_(id) : nullptr;
  if (!identity) return std::nullopt;
  return security::subjectOf(identity->certificate, id, identity->name);
}

std::string OwnerGuard::describe(PeisId id) const {
  const auto who = subject(id);
  std::string text = "PEIS " + std::to_string(id);
  if (!who) return text;
  text += " (principal '" + who->principal + "'";
  for (std::size_t i = 0; i < who->groups.size(); ++i) {
    text += (i == 0 ? ", groups " : ", ") + who->groups[i];
  }
  return text + ")";
}

Error OwnerGuard::deny(std::uint64_t& counter, ErrorCode code, std::string message) {
  ++counter;
  lastDenial_ = message;
  deniedChanged_ = true;
  log::debug(0, "denied: " + message);
  return Error(code, std::move(message));
}

std::optional<Error> OwnerGuard::checkWrite(PeisId self, PeisId source, const wire::Write& write,
                                            const Tuple* current) {
  const auto& key = write.tuple.key;
  const auto name = std::to_string(self) + "." + key;
  const bool policyKey = key == special::kPolicy && secured();
  if (isKernelKey(key) && !policyKey &&
      (key != special::kDoQuit || write.op != wire::WriteOp::Set)) {
    return deny(stats_.kernelTupleRefused, ErrorCode::Refused,
                name + " is written by PEIS " + std::to_string(self) +
                    "'s kernel only (of the kernel.* tuples, only kernel.do-quit takes a "
                    "remote set" +
                    (secured() ? ", and kernel.policy from an administrator)" : ")"));
  }
  if (secured()) {
    const auto who = subject(source);
    if (!who) {
      return deny(stats_.policyDenied, ErrorCode::Refused,
                  "PEIS " + std::to_string(source) + " proved no identity to PEIS " +
                      std::to_string(self) + ": it may not write " + name);
    }
    if (policyKey) {
      if (write.op != wire::WriteOp::Set || !policy_->isAdmin(*who)) {
        return deny(stats_.policyDenied, ErrorCode::Refused,
                    describe(source) + " may not replace the policy of PEIS " +
                        std::to_string(self) + " (only its administrators set kernel.policy)");
      }
      try {
        security::Policy::parse(write.tuple.data, name);
      } catch (const Error& e) {
        return deny(stats_.policyDenied, ErrorCode::InvalidConfig,
                    std::string("the new policy is refused: ") + e.what());
      }
    } else if (!policy_->allows(*who, opOf(write.op), key)) {
      return deny(stats_.policyDenied, ErrorCode::Refused,
                  describe(source) + " may not " + security::Policy::opName(opOf(write.op)) + " " +
                      name + " (the policy of PEIS " + std::to_string(self) + ")");
    }
  }
  if (write.op == wire::WriteOp::Erase) return std::nullopt;  // frees, never takes
  std::size_t bytes = write.tuple.data.size();
  if (write.op == wire::WriteOp::Append && current) bytes += current->data.size();
  if (auto problem = quota_.check(writer(source), key, bytes, "PEIS " + std::to_string(source))) {
    return deny(stats_.quotaRefused, ErrorCode::Refused,
                "write to " + name + " refused: " + *problem);
  }
  return std::nullopt;
}

void OwnerGuard::ownEvent(PeisId self, EventKind kind, const Tuple& tuple) {
  if (secured() && kind == EventKind::Changed && tuple.key == special::kPolicy &&
      tuple.data != policy_->text()) {
    try {
      policy_ = std::make_shared<const security::Policy>(
          security::Policy::parse(tuple.data, std::to_string(self) + ".kernel.policy"));
      policyChanged_ = true;
      log::info(self, "policy replaced by PEIS " + std::to_string(tuple.creator));
    } catch (const Error& e) {  // a local write of a broken policy: the old one holds
      log::error(self, std::string("kernel.policy not adopted: ") + e.what());
    }
  }
  // Changes by this PEIS of keys no remote writer holds: nothing to do.
  if (quota_.empty() && tuple.creator == self) return;
  if (kind == EventKind::Deleted) return quota_.onDeleted(tuple.key);
  quota_.onChanged(tuple.key, tuple.creator == self ? std::string() : writer(tuple.creator),
                   tuple.data.size());
}

std::shared_ptr<const OwnerGuard::ReadAccess> OwnerGuard::readAccess(PeisId subscriber) const {
  if (!secured()) return nullptr;
  auto who = subject(subscriber);
  if (!who) return std::make_shared<const ReadAccess>(nullptr, security::Subject{});
  return std::make_shared<const ReadAccess>(policy_, std::move(*who));
}

void OwnerGuard::subscriptionFiltered(PeisId self, PeisId subscriber, std::string_view pattern) {
  deny(stats_.policyDenied, ErrorCode::Refused,
       describe(subscriber) + " may not read some of " + std::to_string(self) + "." +
           std::string(pattern) + " (the policy of PEIS " + std::to_string(self) +
           "): it is not sent those");
}

std::optional<std::string> OwnerGuard::refusal(const security::Identity& identity) const {
  if (!policy_) return std::nullopt;
  return policy_->revoked(security::subjectOf(identity.certificate, identity.id, identity.name));
}

std::optional<std::string> OwnerGuard::takeDeniedText() {
  if (!deniedChanged_) return std::nullopt;
  deniedChanged_ = false;
  return std::to_string(stats_.quotaRefused + stats_.kernelTupleRefused + stats_.policyDenied) +
         " denied (policy " + std::to_string(stats_.policyDenied) + ", quota " +
         std::to_string(stats_.quotaRefused) + ", kernel tuples " +
         std::to_string(stats_.kernelTupleRefused) + "); last: " + lastDenial_;
}

}  // namespace peis
