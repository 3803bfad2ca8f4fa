// The monitor's decisions: failures of a deployed configuration, recovery of
// failed parts, and the anti-flap rule.
#include "monitor/health.h"

#include <algorithm>
#include <sstream>

#include "peis/conventions.h"
#include "peis/key.h"

namespace peis::meta {
namespace {

using std::chrono::milliseconds;

const Functionality* functionalityOf(const Model& model, const ActiveInstance& instance) {
  const auto* peis = model.findPeis(instance.peis);
  if (!peis) return nullptr;
  for (const auto& d : peis->components) {
    if (d.component != instance.component) continue;
    for (const auto& f : d.functionalities)
      if (f.name == instance.functionality) return &f;
  }
  return nullptr;
}

std::optional<std::string> valueOf(const ActiveInstance& instance, const std::string& arg) {
  if (!isVariable(arg)) return arg;
  if (arg == kSelfVariable) return instance.peis;
  for (const auto& [var, value] : instance.binding)
    if (var == arg) return value;
  return std::nullopt;
}

// `position.?robot` with ?robot = vac -> `position.vac`.
std::optional<std::string> groundKey(const std::string& key, const ActiveInstance& instance) {
  std::string out;
  for (const auto part : splitKey(key)) {
    const auto value = valueOf(instance, std::string(part));
    if (!value) return std::nullopt;
    out += (out.empty() ? "" : ".") + *value;
  }
  return out;
}

bool contains(const std::string& words, const std::string& word) {
  std::istringstream in(words);
  for (std::string w; in >> w;)
    if (w == word) return true;
  return false;
}

std::string seconds(milliseconds ms) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", static_cast<double>(ms.count()) / 1000.0);
  return buf;
}

}  // namespace

const char* toString(FailureKind kind) {
  switch (kind) {
    case FailureKind::PeisGone:
      return "peis-gone";
    case FailureKind::ComponentError:
      return "component-error";
    case FailureKind::StaleInput:
      return "stale-input";
    case FailureKind::PreconditionLost:
      return "precondition-lost";
  }
  return "?";
}

InstanceSelector selectorOf(const ActiveInstance& instance) {
  InstanceSelector s;
  s.peis = instance.peis;
  s.component = instance.component;
  s.functionality = instance.functionality;
  for (const auto& [var, value] : instance.binding)
    s.binding[isVariable(var) ? var : "?" + var] = value;
  return s;
}

std::vector<ActiveInstance> producersOf(const Configuration& configuration, const Model& model,
                                        const Link& link) {
  std::vector<ActiveInstance> found;
  for (const auto& instance : configuration.instances) {
    if (instance.peisId != link.producerId && instance.peis != link.producerPeis) continue;
    const auto* f = functionalityOf(model, instance);
    if (!f) continue;
    for (const auto& port : f->outputs) {
      if (groundKey(port.outputKey(), instance) == link.producerKey) {
        found.push_back(instance);
        break;
      }
    }
  }
  return found;
}

HealthMonitor::HealthMonitor(MonitorPolicy policy) : policy_(policy) {}

void HealthMonitor::deployed(Configuration configuration, Model model,
                             MonitorClock::time_point now) {
  configuration_ = std::move(configuration);
  model_ = std::move(model);
  deployedAt_ = now;
  active_ = true;
  waitingSince_.clear();
  reported_.clear();
}

void HealthMonitor::clear() {
  active_ = false;
  configuration_ = {};
  waitingSince_.clear();
  reported_.clear();
}

std::vector<Failure> HealthMonitor::observe(const LiveModel& live, MonitorClock::time_point now) {
  std::vector<Failure> failures;
  if (!active_) return failures;
  auto report = [&](const ActiveInstance& instance, FailureKind kind, const std::string& cause,
                    const LivePeis* peis) {
    const auto selector = selectorOf(instance);
    if (!reported_.insert(selector.toString()).second) return;
    failures.push_back(
        Failure{kind, selector, instance.peisId, peis ? peis->incarnation : 0, cause});
  };
  std::set<std::string> facts;
  for (const auto& p : live.peis)
    if (p.alive) facts.insert(p.facts.begin(), p.facts.end());

  for (const auto& instance : configuration_.instances) {
    const auto* peis = live.find(instance.peisId);
    if (!peis || !peis->alive) {
      report(instance, FailureKind::PeisGone, "PEIS " + instance.peis + " is gone", peis);
      continue;
    }
    if (peis->status == conventions::kError) {
      report(instance, FailureKind::ComponentError,
             "the component on " + instance.peis + " is in error" +
                 (peis->causes.empty() ? std::string() : ": " + peis->causes),
             peis);
      continue;
    }
    const auto* f = functionalityOf(model_, instance);
    if (!f) continue;
    for (const auto& text : f->preconditions) {
      const auto pre = Precondition::parse(text);
      if (!pre || pre->disequality) continue;
      Term atom = pre->atom;
      bool ground = true;
      for (auto& arg : atom.args) {
        const auto value = valueOf(instance, arg);
        if (!value) ground = false;
        if (value) arg = *value;
      }
      if (ground && !facts.count(atom.toString())) {
        report(instance, FailureKind::PreconditionLost,
               "precondition " + atom.toString() + " of " + selectorOf(instance).toString() +
                   " no longer holds",
               peis);
        break;
      }
    }
  }

  for (const auto& link : configuration_.links) {
    const auto key = std::make_pair(link.consumerId, link.consumerKey);
    const auto* consumer = live.find(link.consumerId);
    const auto input = conventions::inputOfMetaKey(link.consumerKey);
    const bool waiting = consumer && consumer->alive && consumer->status == conventions::kWaiting &&
                         contains(consumer->causes, input);
    // Judged only while the consumer points where the configuration says
    // (anything else is drift, which deployment corrects).
    bool pointsThere = false;
    if (consumer) {
      const auto pointed = consumer->links.find(link.consumerKey);
      pointsThere = pointed != consumer->links.end() &&
                    live.canonicalTarget(pointed->second) ==
                        std::to_string(link.producerId) + "." + link.producerKey;
    }
    if (!waiting || !pointsThere) {
      waitingSince_.erase(key);
      continue;
    }
    const auto since = waitingSince_.try_emplace(key, now).first->second;
    if (now - since < policy_.grace || now - deployedAt_ < policy_.settle) continue;
    const auto* producer = live.find(link.producerId);
    if (!producer || !producer->alive) continue;  // reported as gone above
    // A producer that waits on its own inputs is not at fault: its suppliers are.
    if (producer->status == conventions::kWaiting || producer->status == conventions::kInitializing)
      continue;
    const auto waited = std::chrono::duration_cast<milliseconds>(now - since);
    const auto cause = "input " + input + " of " + link.consumerPeis + " stale for " +
                       seconds(waited) + ": " + link.producerPeis + "." + link.producerKey +
                       " not delivered";
    const auto producers = producersOf(configuration_, model_, link);
    for (const auto& instance : producers)
      report(instance, FailureKind::StaleInput, cause, producer);
    if (producers.empty()) {
      // No instance known to write it (a plain PEIS): the whole PEIS is blamed.
      InstanceSelector all;
      all.peis = link.producerPeis;
      if (reported_.insert(all.toString()).second)
        failures.push_back(
            Failure{FailureKind::StaleInput, all, link.producerId, producer->incarnation, cause});
    }
  }
  return failures;
}

std::optional<MonitorClock::time_point> HealthMonitor::nextCheck() const {
  if (!active_ || waitingSince_.empty()) return std::nullopt;
  std::optional<MonitorClock::time_point> next;
  for (const auto& [key, since] : waitingSince_) {
    const auto at = std::max(since + policy_.grace, deployedAt_ + policy_.settle);
    if (!next || at < *next) next = at;
  }
  return next;
}

FailedParts::FailedParts(milliseconds hold, milliseconds retryAfter)
    : hold_(hold), retryAfter_(retryAfter) {}

bool FailedParts::add(const Failure& failure, MonitorClock::time_point now) {
  if (failure.kind == FailureKind::PreconditionLost) return false;
  const auto key = failure.instance.toString();
  if (parts_.count(key)) return false;
  FailedPart part{failure, now, milliseconds(0), std::nullopt};
  if (failure.kind == FailureKind::StaleInput) {
    auto& backoff = backoff_[key];
    backoff = backoff.count() == 0 ? retryAfter_ : backoff * 2;
    part.retryAfter = backoff;
  }
  parts_.emplace(key, std::move(part));
  return true;
}

std::vector<Failure> FailedParts::recovered(const LiveModel& live, MonitorClock::time_point now) {
  std::vector<Failure> back;
  for (auto it = parts_.begin(); it != parts_.end();) {
    auto& part = it->second;
    const auto& f = part.failure;
    // The PEIS now carrying the failed instance's PEIS name (it may have
    // restarted under another id).
    const auto* peis = live.findByName(f.instance.peis);
    if (!peis) peis = live.find(f.peisId);
    bool healthy = false;
    if (peis && peis->alive) {
      const bool restarted =
          peis->id != f.peisId || (f.incarnation != 0 && peis->incarnation != f.incarnation);
      switch (f.kind) {
        case FailureKind::PeisGone:
          healthy = true;
          break;
        case FailureKind::ComponentError:
          healthy = peis->status != conventions::kError;
          break;
        case FailureKind::StaleInput:
          healthy = restarted || now - part.since >= part.retryAfter;
          break;
        case FailureKind::PreconditionLost:
          healthy = true;
          break;
      }
    }
    if (!healthy) {
      part.healthySince.reset();
      ++it;
      continue;
    }
    if (!part.healthySince) part.healthySince = now;
    if (now - *part.healthySince < hold_) {
      ++it;
      continue;
    }
    back.push_back(f);
    it = parts_.erase(it);
  }
  return back;
}

std::vector<InstanceSelector> FailedParts::selectors() const {
  std::vector<InstanceSelector> all;
  for (const auto& [key, part] : parts_) all.push_back(part.failure.instance);
  return all;
}

std::optional<MonitorClock::time_point> FailedParts::nextCheck() const {
  std::optional<MonitorClock::time_point> next;
  auto consider = [&](MonitorClock::time_point at) {
    if (!next || at < *next) next = at;
  };
  for (const auto& [key, part] : parts_) {
    if (part.healthySince) consider(*part.healthySince + hold_);
    if (part.failure.kind == FailureKind::StaleInput) consider(part.since + part.retryAfter);
  }
  return next;
}

bool worthSwitching(double currentCost, double candidateCost, double margin) {
  return candidateCost <= (1.0 - margin) * currentCost - 1e-9;
}

}  // namespace peis::meta
