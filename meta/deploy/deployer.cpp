// Deployment with ordered compare-and-set locks, intent records and undo
// (see deployer.h for the protocol).
#include "deploy/deployer.h"

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "peis/error.h"
#include "peis/key.h"
#include "peis/log.h"

namespace peis::meta {
namespace {

constexpr const char* kLockKey = "config.lock";
constexpr const char* kOwnedKey = "config.owned";
// A lock tuple keeps its history; past this many lines the holder compacts it.
constexpr std::size_t kLockHistoryLines = 16;

using Clock = std::chrono::steady_clock;

std::string describePeis(int id, const std::string& name) {
  return "PEIS " +
         (name.empty() ? std::to_string(id) : "'" + name + "' (" + std::to_string(id) + ")");
}

// Several remote writes at once; waits for all their answers.
class Batch {
 public:
  explicit Batch(Kernel& kernel) : kernel_(kernel) {}
  void set(int peis, const std::string& key, const std::string& value, bool meta) {
    WriteOptions options;
    if (meta) options.mimetype = kMetaMimetype;
    std::size_t index;
    {
      std::lock_guard lock(mu_);
      ++pending_;
      index = results_.size();
      results_.push_back(Result{peis, key, std::nullopt});
    }
    try {
      kernel_.setAsync(peis, key, value, options,
                       [this, index](const std::optional<Error>& error, std::uint64_t) {
                         finish(index,
                                error ? std::optional<std::string>(error->what()) : std::nullopt);
                       });
    } catch (const Error& e) {
      finish(index, std::string(e.what()));
    }
  }
  struct Result {
    int peis;
    std::string key;
    std::optional<std::string> error;
  };
  // Waits for every answer (the kernel's write timeout bounds each one).
  std::vector<Result> wait() {
    std::unique_lock lock(mu_);
    done_.wait(lock, [this] { return pending_ == 0; });
    return results_;
  }

 private:
  void finish(std::size_t index, std::optional<std::string> error) {
    std::lock_guard lock(mu_);
    results_[index].error = std::move(error);
    if (--pending_ == 0) done_.notify_all();
  }
  Kernel& kernel_;
  std::mutex mu_;
  std::condition_variable done_;
  std::size_t pending_ = 0;
  std::vector<Result> results_;
};

}  // namespace

Deployer::Deployer(Kernel& kernel, DeployOptions options) : kernel_(kernel), options_(options) {}

bool Deployer::alive(int peis) const {
  for (const auto& p : kernel_.peers())
    if (p.id == peis) return true;
  return false;
}

std::optional<std::string> Deployer::currentValue(int peis, const std::string& key) const {
  auto t = kernel_.get(peis, key);
  if (!t) return std::nullopt;
  return t->data;
}

std::map<int, std::set<std::string>> Deployer::ownedRecords(const LiveModel& live) const {
  std::map<int, std::set<std::string>> owned;
  for (const auto& t : kernel_.find(Pattern(kOwnedKey))) {
    const auto* p = live.find(t.owner);
    if ((p && !p->alive) || !alive(t.owner)) continue;  // gone: nothing to switch off there
    auto record = OwnedRecord::parse(t.data);
    if (!record.keys.empty()) owned[t.owner] = std::move(record.keys);
  }
  return owned;
}

std::uint64_t Deployer::nextGeneration(const LiveModel&) const {
  std::uint64_t highest = 0;
  for (const auto& t : kernel_.find(Pattern(kLockKey))) {
    if (auto line = lastLockLine(t.data)) highest = std::max(highest, line->generation);
  }
  for (const auto& t : kernel_.find(Pattern(kOwnedKey)))
    highest = std::max(highest, OwnedRecord::parse(t.data).generation);
  return highest + 1;
}

std::vector<PeisChanges> Deployer::pendingChanges(const Configuration& configuration,
                                                  const LiveModel& live,
                                                  const std::set<int>& leaveAlone) const {
  return changesExcept(configuration, live, leftAlone(configuration, leaveAlone));
}

std::set<int> Deployer::leftAlone(const Configuration& configuration,
                                  const std::set<int>& leaveAlone) {
  const auto desired = desiredState(configuration);
  std::set<int> skipped;
  for (int id : leaveAlone)
    if (!desired.tuples.count(id)) skipped.insert(id);
  return skipped;
}

std::vector<PeisChanges> Deployer::changesExcept(const Configuration& configuration,
                                                 const LiveModel& live,
                                                 const std::set<int>& excluded) const {
  auto owned = ownedRecords(live);
  for (int id : excluded) owned.erase(id);
  return diffDeployment(
      desiredState(configuration), owned,
      [this](int peis, const std::string& key) { return currentValue(peis, key); },
      [&live](const std::string& data) { return live.canonicalTarget(data); });
}

bool Deployer::acquire(int peis, const std::string& name, std::uint64_t generation, Held& held,
                       std::string& error) {
  const auto deadline = Clock::now() + options_.lockWait;
  const int me = kernel_.id();
  while (true) {
    const auto tuple = kernel_.get(peis, kLockKey);
    const std::uint64_t seqno = tuple ? tuple->seqno : 0;
    const std::string text = tuple ? tuple->data : "";
    const auto last = lastLockLine(text);
    if (last && last->deploying && last->holder != me && alive(last->holder)) {
      if (Clock::now() >= deadline) {
        error = describePeis(peis, name) + " is being configured by PEIS " +
                std::to_string(last->holder) + " (generation " + std::to_string(last->generation) +
                ")";
        return false;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      continue;
    }
    const auto line = LockLine{generation, me, true}.format();
    try {
      const auto appended =
          kernel_.append(peis, kLockKey, text.empty() ? line : "\n" + line, seqno);
      held = Held{peis, appended.seqno};
      if (lineCount(text) + 1 > kLockHistoryLines) {
        // Ours now: nobody else writes it until we release.
        held.seqno = kernel_.set(peis, kLockKey, line).seqno;
      }
      return true;
    } catch (const Error& e) {
      if (e.code() != ErrorCode::Conflict) {
        error = describePeis(peis, name) + " did not take the deployment lock: " + e.what();
        return false;
      }
      if (Clock::now() >= deadline) {
        error = describePeis(peis, name) + ": its deployment lock kept changing";
        return false;
      }
      // Our copy is behind: wait for the owner's newer value to arrive.
      const auto until = Clock::now() + std::chrono::milliseconds(200);
      while (Clock::now() < until) {
        const auto now = kernel_.get(peis, kLockKey);
        if ((now ? now->seqno : 0) != seqno) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    }
  }
}

void Deployer::release(const std::vector<Held>& held, std::uint64_t generation) {
  const auto line = "\n" + LockLine{generation, kernel_.id(), false}.format();
  for (const auto& h : held) {
    try {
      kernel_.append(h.peis, kLockKey, line, h.seqno);
    } catch (const Error& e) {
      if (e.code() == ErrorCode::Conflict)
        log::warn(kernel_.id(), "deployment: the lock on PEIS " + std::to_string(h.peis) +
                                    " was taken over while generation " +
                                    std::to_string(generation) + " held it");
      // Unreachable: the PEIS is gone, its lock with it.
    }
  }
}

DeployResult Deployer::deploy(const Configuration& configuration, const LiveModel& live,
                              const std::set<int>& leaveAlone) {
  const auto start = Clock::now();
  DeployResult result;
  auto finish = [&](DeployResult r) {
    r.milliseconds = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    return r;
  };
  auto nameOf = [&live](int id) {
    const auto* p = live.find(id);
    return p ? p->name : std::string();
  };
  const auto desired = desiredState(configuration);
  for (int id : desired.peis()) {
    if (!alive(id)) {
      result.failedPeis = id;
      result.failedPeisName = nameOf(id);
      result.error = describePeis(id, nameOf(id)) + " is not reachable";
      return finish(result);
    }
  }
  std::set<int> skipped = leftAlone(configuration, leaveAlone);
  if (changesExcept(configuration, live, skipped).empty()) {
    result.ok = result.unchanged = true;
    return finish(result);
  }
  result.generation = nextGeneration(live);
  std::vector<Held> held;
  std::set<int> touched = desired.peis();
  // PEIS locked only to switch off what an earlier configuration left there:
  // one that does not answer is left as it is (its record stays, a later
  // deployment tries again), so a hung PEIS cannot hold up a repair.
  for (int attempt = 0;; ++attempt) {
    for (const auto& [id, keys] : ownedRecords(live)) touched.insert(id);
    for (int id : touched) {
      if (skipped.count(id)) continue;
      Held h{};
      std::string error;
      if (!acquire(id, nameOf(id), result.generation, h, error)) {
        if (!desired.tuples.count(id)) {
          result.warnings.push_back(error + " (what it holds of an earlier configuration stays)");
          skipped.insert(id);
          continue;
        }
        release(held, result.generation);
        result.failedPeis = id;
        result.failedPeisName = nameOf(id);
        result.error = error;
        return finish(result);
      }
      held.push_back(h);
    }
    // Records that appeared while we locked (another deployer finished
    // meanwhile) must be locked too: start again with them.
    bool grown = false;
    for (const auto& [id, keys] : ownedRecords(live)) grown = grown || !touched.count(id);
    if (!grown || attempt == 3) break;
    release(held, result.generation);
    held.clear();
  }
  const auto changes = changesExcept(configuration, live, skipped);
  result.peisTouched = changes.size();
  auto failed = [&](const std::vector<Batch::Result>& results) -> const Batch::Result* {
    for (const auto& r : results)
      if (r.error) return &r;
    return nullptr;
  };
  auto fail = [&](const Batch::Result& r, const std::string& what) {
    release(held, result.generation);
    result.failedPeis = r.peis;
    result.failedPeisName = nameOf(r.peis);
    result.error = describePeis(r.peis, nameOf(r.peis)) + " did not accept " + what + " (" + r.key +
                   "): " + *r.error;
    return finish(result);
  };
  // 1. Intent: every key this deployment may write is in the records first.
  std::map<int, std::string> previousRecords;  // to put back if the deployment fails
  {
    Batch intent(kernel_);
    for (const auto& c : changes) {
      std::set<std::string> keys = c.ownedBefore;
      keys.insert(c.ownedAfter.begin(), c.ownedAfter.end());
      if (keys == c.ownedBefore) continue;
      previousRecords[c.peis] = currentValue(c.peis, kOwnedKey).value_or("");
      intent.set(c.peis, kOwnedKey, OwnedRecord{result.generation, kernel_.id(), keys}.format(),
                 false);
    }
    const auto results = intent.wait();
    if (const auto* r = failed(results)) return fail(*r, "the configuration record");
  }
  // 2. The writes, all at once. A key of the new configuration that is not
  // taken fails the deployment; a key only switched off that is not taken
  // (its PEIS refuses) is given up with a warning, so one such PEIS cannot
  // block every later configuration.
  Batch writes(kernel_);
  std::vector<TupleWrite> sent;
  std::vector<bool> wanted;
  for (const auto& c : changes) {
    for (const auto& w : c.writes) {
      writes.set(w.peis, w.key, w.value, isMetaKey(w.key));
      sent.push_back(w);
      wanted.push_back(c.ownedAfter.count(w.key) > 0);
    }
  }
  const auto writeResults = writes.wait();
  for (std::size_t i = 0; i < sent.size(); ++i) {
    if (!writeResults[i].error || wanted[i]) continue;
    result.warnings.push_back(describePeis(sent[i].peis, nameOf(sent[i].peis)) +
                              " did not switch off " + sent[i].key + ": " + *writeResults[i].error);
  }
  const Batch::Result* refused = nullptr;
  for (std::size_t i = 0; i < sent.size() && !refused; ++i)
    if (writeResults[i].error && wanted[i]) refused = &writeResults[i];
  if (refused) {
    // Undo what did go through, so the ecology keeps the configuration it had.
    Batch undo(kernel_);
    for (std::size_t i = 0; i < sent.size(); ++i) {
      if (writeResults[i].error) continue;
      undo.set(sent[i].peis, sent[i].key, sent[i].previous.value_or(switchedOffValue(sent[i].key)),
               isMetaKey(sent[i].key));
    }
    for (const auto& [peis, text] : previousRecords) undo.set(peis, kOwnedKey, text, false);
    undo.wait();
    return fail(*refused, "the write");
  }
  result.writes = sent.size();
  // 3. The records name what this configuration wrote, and only that.
  {
    Batch records(kernel_);
    for (const auto& c : changes) {
      if (c.ownedAfter.empty() && c.ownedBefore.empty()) continue;
      records.set(c.peis, kOwnedKey,
                  OwnedRecord{result.generation, kernel_.id(), c.ownedAfter}.format(), false);
    }
    const auto results = records.wait();
    if (const auto* r = failed(results)) return fail(*r, "the configuration record");
  }
  release(held, result.generation);
  result.ok = true;
  return finish(result);
}

}  // namespace peis::meta
