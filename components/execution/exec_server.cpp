// The executing side of the ExecGoal protocol (see exec_server.h).
#include "execution/exec_server.h"

#include <cmath>
#include <memory>
#include <sstream>

namespace peis::exec {

ExecServer::ExecServer(Kernel& kernel, Check check, OnGoal onGoal, WriteGate otherGate)
    : kernel_(kernel), check_(std::move(check)), onGoal_(std::move(onGoal)) {
  kernel_.setWriteGate(
      [this, otherGate](const Tuple& requested, PeisId writer, const WriteDecision& decide) {
        if (requested.key != kExecGoal)
          return otherGate ? otherGate(requested, writer, decide) : false;
        std::string problem;
        const auto action = parseAction(requested.data, &problem);
        if (action) {
          if (const auto why = check_(*action)) problem = *why;
        }
        if (!action || !problem.empty()) {
          ++refused_;
          decide(Error(ErrorCode::Refused,
                       "ExecGoal '" + requested.data.substr(0, 80) + "' refused: " + problem));
          return true;
        }
        return false;
      });
  callback_ = kernel_.onChange(Pattern::exact(kernel_.id(), kExecGoal), [this](const Tuple& t) {
    std::string problem;
    auto action = parseAction(t.data, &problem);
    if (action) {
      if (const auto why = check_(*action)) {
        problem = *why;
        action.reset();
      }
    }
    if (!action) {
      publish({ExecState::Failed, t.seqno, "Malformed",
               "malformed goal '" + t.data.substr(0, 80) + "': " + problem});
      return;
    }
    onGoal_(*action, t.seqno);
  });
}

ExecServer::~ExecServer() {
  kernel_.removeCallback(callback_);
  kernel_.setWriteGate({});
}

void ExecServer::publish(const ExecStatus& status) { kernel_.set(kExecStatus, status.toString()); }

std::optional<double> sensorSeconds(const Tuple& tuple) {
  if (tuple.ts_user == kNoTime) return std::nullopt;
  return std::chrono::duration<double>(tuple.ts_user.time_since_epoch()).count();
}

std::optional<std::vector<double>> parseNumbers(std::string_view text) {
  std::vector<double> out;
  std::string_view rest = text;
  while (!rest.empty()) {
    const std::size_t start = rest.find_first_not_of(" \t\r\n");
    if (start == std::string_view::npos) break;
    rest.remove_prefix(start);
    const std::size_t end = rest.find_first_of(" \t\r\n");
    const auto value = parseNumber(rest.substr(0, end));
    if (!value) return std::nullopt;
    out.push_back(*value);
    if (end == std::string_view::npos) break;
    rest.remove_prefix(end);
  }
  return out;
}

namespace {

// One wait for a peer: held only by its pending timer, so it goes away once
// the peer is found.
struct PeerWait : std::enable_shared_from_this<PeerWait> {
  PeerWait(Kernel& k, std::string n, std::function<void(std::optional<PeisId>)> t,
           std::optional<std::chrono::steady_clock::time_point> d)
      : kernel(k), name(std::move(n)), then(std::move(t)), deadline(d) {}
  void attempt() {
    try {
      const PeisId id = kernel.resolveOwner(name);
      then(id);
      return;
    } catch (const Error&) {
    }
    if (deadline && std::chrono::steady_clock::now() >= *deadline) return then(std::nullopt);
    kernel.after(std::chrono::milliseconds(100), [self = shared_from_this()] { self->attempt(); });
  }
  Kernel& kernel;
  std::string name;
  std::function<void(std::optional<PeisId>)> then;
  std::optional<std::chrono::steady_clock::time_point> deadline;
};

}  // namespace

void whenPeerKnown(Kernel& kernel, const std::string& name, std::function<void(PeisId)> then) {
  auto wait = std::make_shared<PeerWait>(
      kernel, name, [then = std::move(then)](std::optional<PeisId> id) { then(*id); },
      std::nullopt);
  kernel.post([wait] { wait->attempt(); });
}

void resolvePeer(Kernel& kernel, const std::string& name, std::chrono::milliseconds timeout,
                 std::function<void(std::optional<PeisId>)> then) {
  auto wait = std::make_shared<PeerWait>(kernel, name, std::move(then),
                                         std::chrono::steady_clock::now() + timeout);
  kernel.post([wait] { wait->attempt(); });
}

}  // namespace peis::exec
