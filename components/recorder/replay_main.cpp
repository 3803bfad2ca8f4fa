// peis-replay (`peis replay FILE.db`): publishes a recording's changes and
// deletions again with their recorded timing (scaled by --speed): as
// stand-ins of the recorded owners (a PEIS with each owner's id and name,
// its tuples under their own keys), or with --prefix P as one PEIS that
// writes P.<owner>.<key>. docs/operating.md says what happens when a
// recorded owner is alive.
#include <peis/kernel.h>

#include <atomic>
#include <condition_variable>
#include <iostream>
#include <map>
#include <mutex>
#include <thread>

#include "common/command_line.h"
#include "recorder/program_args.h"
#include "recorder/recording_reader.h"
#include "recorder/replay_plan.h"

namespace {

using namespace std::chrono_literals;
using peis::recorder::ProgramArgs;

const char* kUsage = R"usage(Usage: peis-replay FILE.db [OPTIONS] [--peis-* flags]
       peis replay FILE.db [OPTIONS]

Publishes the changes and deletions of a recording again, each its recorded
gap after the one before (divided by --speed). Without --prefix each recorded owner gets a
stand-in: a PEIS with the owner's id and name that writes the tuples under
their own keys (subscribers of the original see the replay). A recorded
owner that is alive keeps its id: peis-replay then refuses, unless --prefix.
With --prefix P one PEIS writes every tuple as P.<owner>.<key>. The writer's
stamps are new (ts_write, seqno, creator); data, mimetype, encoding and
ts_user are the recorded ones, an expiry becomes the same time to live.

Options:
  --speed X               X times the recorded speed (default 1; 0.01..1000)
  --prefix P              replay under P.<owner>.<key> of one PEIS
  --loop                  start again after the last event, until stopped
  --wait-subscribers N    start once every replaying PEIS has N subscribers
  --wait S                how long to look for live recorded owners before a
                          stand-in replay (default 2)
  --help                  this text
)usage";

int usageError(const std::string& why) {
  std::cerr << "peis-replay: " << why << " (see --help)\n";
  return 2;
}

// A PEIS that publishes: a stand-in of `standsFor`, or the prefix replayer (0).
struct Publisher {
  std::unique_ptr<peis::Kernel> kernel;
  peis::PeisId standsFor = 0;
  bool lost = false;  // a live PEIS took the id back
};

// The PEIS reachable once membership has been quiet for 500 ms (at most `wait`).
std::vector<peis::PeerInfo> settledPeers(const peis::Kernel& kernel,
                                         std::chrono::milliseconds wait) {
  const auto until = std::chrono::steady_clock::now() + wait;
  auto peers = kernel.peers();
  auto quietSince = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(20ms);
    auto now = kernel.peers();
    const auto sameIds = [](const auto& a, const auto& b) {
      if (a.size() != b.size()) return false;
      for (std::size_t i = 0; i < a.size(); ++i)
        if (a[i].id != b[i].id) return false;
      return true;
    };
    if (!sameIds(now, peers)) {
      peers = std::move(now);
      quietSince = std::chrono::steady_clock::now();
    } else if (std::chrono::steady_clock::now() - quietSince >= 500ms && peers.size() > 1) {
      break;
    }
  }
  return peers;
}

std::size_t subscriberCount(const peis::Kernel& kernel) {
  const auto list = kernel.get(peis::special::kSubscribers);
  std::size_t count = 0;
  bool inWord = false;
  for (const char c : list ? list->data : "") {
    if (c != ' ' && !inWord) ++count;
    inWord = c != ' ';
  }
  return count;
}

std::string standInName(peis::PeisId owner, const std::string& recorded) {
  return !recorded.empty() && !peis::nameProblem(recorded) ? recorded
                                                           : "replay-" + std::to_string(owner);
}

}  // namespace

int main(int argc, char** argv) {
  peis::Options options;
  if (const auto code = peis::components::parsePeisOptions(argc, argv, "peis-replay", kUsage,
                                                           "peis-replay", options))
    return *code;
  ProgramArgs args;
  double speed = 1, waitSeconds = 2, subscribers = 0;
  try {
    args = peis::recorder::parseProgramArgs(
        argc, argv, {"--speed", "--prefix", "--wait-subscribers", "--wait"}, {"--loop"});
    speed = args.number("--speed", 1, 0.01, 1000);
    waitSeconds = args.number("--wait", 2, 0, 3600);
    subscribers = args.number("--wait-subscribers", 0, 0, 100000);
  } catch (const std::invalid_argument& e) {
    return usageError(e.what());
  }
  if (args.positional.size() != 1) return usageError("give one FILE.db");
  const auto prefix = args.value("--prefix");
  if (prefix) {
    if (const auto problem = peis::recorder::prefixProblem(*prefix))
      return usageError("--prefix '" + *prefix + "': " + *problem);
  } else if (options.id) {
    return usageError("--peis-id goes with --prefix only: each stand-in takes its owner's id");
  }
  const std::string& path = args.positional[0];
  std::unique_ptr<peis::recorder::RecordingReader> reader;
  std::map<peis::PeisId, std::string> owners;
  try {
    reader = std::make_unique<peis::recorder::RecordingReader>(path);
    owners = reader->owners(!prefix);  // a stand-in replays no kernel.* tuples
  } catch (const peis::Error& e) {
    std::cerr << "peis-replay: " << e.what() << "\n";
    return 1;
  }

  std::vector<Publisher> publishers;
  try {
    if (prefix) {
      publishers.push_back({std::make_unique<peis::Kernel>(options), 0});
    } else {
      {
        // Is any recorded owner alive? Its id is then not ours to take.
        peis::Options probeOptions = options;
        probeOptions.tool = true;
        probeOptions.name = "peis-replay-probe";
        peis::Kernel probe(probeOptions);
        std::string alive;
        for (const auto& peer : settledPeers(
                 probe, std::chrono::milliseconds(static_cast<long long>(waitSeconds * 1000)))) {
          if (owners.count(peer.id) && peer.id != probe.id())
            alive += (alive.empty() ? "" : ", ") + std::to_string(peer.id) + " (" + peer.name + ")";
        }
        if (!alive.empty()) {
          std::cerr << "peis-replay: PEIS " << alive << " of the recording "
                    << (alive.find(',') == std::string::npos ? "is" : "are")
                    << " alive in ecology '" << options.ecology
                    << "': a live PEIS keeps its id, so a stand-in cannot replay as it. Stop it, "
                       "replay with --prefix P, or in another --peis-ecology.\n";
          return 1;
        }
      }
      for (const auto& [owner, name] : owners) {
        peis::Options o = options;
        o.id = owner;
        o.name = standInName(owner, name);
        o.port = 0;
        publishers.push_back({std::make_unique<peis::Kernel>(o), owner});
      }
    }
  } catch (const peis::Error& e) {  // a TCP port taken, a bad PEIS_DISCOVERY_SCOPE
    return usageError(e.what());
  }
  if (publishers.empty()) {
    std::cerr << "peis-replay: " << path << " holds no events\n";
    return 0;
  }
  std::map<peis::PeisId, Publisher*> byOwner;
  for (auto& p : publishers) byOwner[p.standsFor] = &p;
  peis::Kernel& main = *publishers.front().kernel;

  std::mutex mu;
  std::condition_variable wake;
  bool stop = false;
  std::uint64_t replayed = 0, deleted = 0, skipped = 0, loops = 0;
  std::thread replay([&] {
    const auto stopped = [&] {
      std::lock_guard lock(mu);
      return stop;
    };
    // Subscribers first, when asked for.
    while (subscribers > 0 && !stopped()) {
      bool all = true;
      for (auto& p : publishers) all = all && subscriberCount(*p.kernel) >= subscribers;
      if (all) break;
      std::unique_lock lock(mu);
      wake.wait_for(lock, 10ms, [&] { return stop; });
    }
    std::map<std::string, bool> reported;
    const auto skip = [&](const std::string& why) -> void {
      ++skipped;
      if (!reported[why]) std::cerr << "peis-replay: skipping: " << why << std::endl;
      reported[why] = true;
    };
    // One recorded event, published by its owner's stand-in or the prefix PEIS.
    const auto publish = [&](const peis::recorder::StoredEvent& e) {
      Publisher* p = byOwner[prefix ? 0 : e.tuple.owner];
      if (p == nullptr) return;
      if (!prefix && !p->lost && p->kernel->id() != p->standsFor) {
        p->lost = true;
        std::cerr << "peis-replay: a live PEIS " << p->standsFor
                  << " appeared and keeps its id; its stand-in (now PEIS " << p->kernel->id()
                  << ") stops replaying" << std::endl;
      }
      if (p->lost) {
        ++skipped;
        return;
      }
      std::string why;
      const auto key = peis::recorder::replayKey(e.tuple.owner, e.tuple.key, prefix, &why);
      if (!key) return skip(e.tuple.fullName() + ": " + why);
      try {
        if (e.deleted) {
          p->kernel->erase(*key);
          ++deleted;
        } else {
          p->kernel->set(*key, e.tuple.data, peis::recorder::replayOptions(e.tuple));
        }
        ++replayed;
      } catch (const peis::Error& error) {
        skip(e.tuple.fullName() + ": " + error.what());
      }
    };
    try {
      do {
        reader->rewind();
        peis::recorder::StoredEvent e;
        // Each event comes its recorded gap (divided by the speed) after the
        // previous one was published: a stall delays what follows rather
        // than bunching it up.
        std::optional<peis::Timestamp> previousReceived;
        auto previousDone = std::chrono::steady_clock::now();
        while (!stopped() && reader->next(e)) {
          const auto due =
              previousDone +
              (previousReceived ? peis::recorder::replayOffset(e.received, *previousReceived, speed)
                                : std::chrono::microseconds(0));
          {
            std::unique_lock lock(mu);
            if (wake.wait_until(lock, due, [&] { return stop; })) break;
          }
          publish(e);
          previousReceived = e.received;
          previousDone = std::chrono::steady_clock::now();
        }
        ++loops;
      } while (args.has("--loop") && !stopped());
    } catch (const peis::Error& error) {
      std::cerr << "peis-replay: " << error.what() << std::endl;
    }
    main.quit("the recording is replayed");
  });

  std::cerr << "peis-replay: " << path << " as "
            << (prefix ? "PEIS " + std::to_string(main.id()) + " under " + *prefix + ".<owner>"
                       : std::to_string(publishers.size()) + " stand-in(s)")
            << ", speed " << speed << std::endl;
  const std::string reason = main.run();
  {
    std::lock_guard lock(mu);
    stop = true;
  }
  wake.notify_all();
  replay.join();
  std::cerr << "peis-replay: " << reason << "; " << replayed << " events (" << deleted
            << " deletions) in " << loops << " pass(es), " << skipped << " skipped" << std::endl;
  return 0;
}
