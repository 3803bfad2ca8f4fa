// peis-record (`peis record PATTERN... -o FILE.db`): subscribes to the
// patterns and stores every change and deletion of a matching tuple, with
// all its meta data, in an SQLite recording. The kernel thread only queues
// each event; RecordingWriter commits them on its own thread.
// docs/operating.md.
#include <peis/kernel.h>

#include <atomic>
#include <filesystem>
#include <future>
#include <iostream>
#include <memory>

#include "common/command_line.h"
#include "recorder/program_args.h"
#include "recorder/recording_writer.h"

namespace {

const char* kUsage = R"usage(Usage: peis-record PATTERN... -o FILE.db [OPTIONS] [--peis-* flags]
       peis record PATTERN... -o FILE.db [OPTIONS]

Records every change and deletion of the tuples matching the patterns, with
all their meta data (owner, key, creator, timestamps, seqno, mimetype,
encoding, data), into the SQLite file FILE.db, until SIGINT or SIGTERM (or
--duration). PATTERN is OWNER.KEYPATTERN, OWNER an id, a name or '*'
('*.**' records everything). The file is committed in batches at least every
--commit-interval, so a recorder that is killed loses at most the changes of
that last interval; the file stays intact (SQLite WAL). Read it with
`peis inspect`, `peis replay` or the sqlite3 shell (docs/operating.md).

Options:
  -o, --output FILE        the recording to create (required)
  --duration S             stop after S seconds
  --force                  replace FILE if it exists
  --commit-interval MS     commit at least this often (default 200)
  --help                   this text
)usage";

int usageError(const std::string& why) {
  std::cerr << "peis-record: " << why << " (see --help)\n";
  return 2;
}

// OWNER.KEYPATTERN with OWNER an id, '*' or a name (resolved in the ecology).
peis::Pattern resolvePattern(peis::Kernel& kernel, const std::string& text) {
  const auto dot = text.find('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == text.size())
    throw peis::Error(peis::ErrorCode::InvalidKey,
                      "'" + text + "' is not OWNER.KEYPATTERN (e.g. '*.**', '12.position.*')");
  const std::string owner = text.substr(0, dot), keys = text.substr(dot + 1);
  if (owner == "*" || peis::parsePeisId(owner)) return peis::Pattern::parse(text);
  peis::validateName(owner);
  const auto id = kernel.waitForPeer(owner, std::chrono::seconds(3));
  if (!id)
    throw peis::Error(peis::ErrorCode::NotFound, "no PEIS named '" + owner + "' is reachable");
  return peis::Pattern(keys, *id);
}

std::string ownerName(const peis::Kernel& kernel, peis::PeisId owner) {
  for (const auto& peer : kernel.peers()) {
    if (peer.id == owner) return peer.name;
  }
  const auto name = kernel.get(owner, peis::special::kName);
  return name ? name->data : "";
}

std::string micros(peis::Timestamp t) { return std::to_string(t.time_since_epoch().count()); }

}  // namespace

int main(int argc, char** argv) {
  peis::Options options;
  if (const auto code = peis::components::parsePeisOptions(argc, argv, "peis-record", kUsage,
                                                           "peis-record", options))
    return *code;
  options.tool = true;  // a tool: `peis ls` leaves it out, it relays for nobody
  peis::recorder::ProgramArgs args;
  double duration = 0, commitMs = 200;
  try {
    args = peis::recorder::parseProgramArgs(argc, argv,
                                            {"--output", "--duration", "--commit-interval"},
                                            {"--force"}, {{"-o", "--output"}});
    duration = args.number("--duration", 0, 0.001, 1e9);
    commitMs = args.number("--commit-interval", 200, 1, 60000);
  } catch (const std::invalid_argument& e) {
    return usageError(e.what());
  }
  if (args.positional.empty()) return usageError("at least one PATTERN is needed");
  const auto output = args.value("--output");
  if (!output || output->empty()) return usageError("-o FILE.db is needed");
  std::error_code ec;
  if (std::filesystem::exists(*output, ec)) {
    if (!args.has("--force")) return usageError(*output + " exists; --force replaces it");
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(*output + suffix, ec);
  }

  std::unique_ptr<peis::Kernel> joined;
  try {
    joined = std::make_unique<peis::Kernel>(options);
  } catch (const peis::Error& e) {  // a TCP port taken, a bad PEIS_DISCOVERY_SCOPE
    return usageError(e.what());
  }
  peis::Kernel& kernel = *joined;
  std::vector<peis::Pattern> patterns;
  std::string patternText;
  try {
    for (const auto& text : args.positional) {
      patterns.push_back(resolvePattern(kernel, text));
      patternText += (patternText.empty() ? "" : " ") + patterns.back().str();
    }
  } catch (const peis::Error& e) {
    if (e.code() != peis::ErrorCode::NotFound) return usageError(e.what());
    std::cerr << "peis-record: " << e.what() << "\n";  // a name no reachable PEIS carries
    return 1;
  }

  const auto hostname = kernel.get(peis::special::kHostname);
  peis::recorder::WriterSettings settings;
  settings.commitInterval = std::chrono::milliseconds(static_cast<long long>(commitMs));
  std::unique_ptr<peis::recorder::RecordingWriter> writer;
  const peis::Timestamp started = peis::systemNow();
  try {
    writer = std::make_unique<peis::recorder::RecordingWriter>(
        *output,
        std::map<std::string, std::string>{{"patterns", patternText},
                                           {"ecology", kernel.options().ecology},
                                           {"host", hostname ? hostname->data : ""},
                                           {"recorder", std::to_string(kernel.id())},
                                           {"started", micros(started)}},
        settings, [&kernel](peis::PeisId owner) { return ownerName(kernel, owner); },
        [&kernel](const std::string& why) { kernel.quit("cannot write the recording: " + why); });
  } catch (const peis::Error& e) {
    std::cerr << "peis-record: " << e.what() << "\n";
    return 1;
  }

  std::atomic<std::uint64_t> changes{0}, deletions{0};
  const auto record = [&](const peis::Tuple& t, bool deleted) {
    if (t.owner == kernel.id()) return;  // this recorder's own kernel tuples
    bool matched = false;
    for (const auto& p : patterns) matched = matched || p.matches(t);
    if (!matched) return;
    (deleted ? deletions : changes).fetch_add(1, std::memory_order_relaxed);
    writer->add({peis::systemNow(), deleted, t});
  };
  // One callback for all patterns: a tuple two patterns match is stored once.
  const auto onChange =
      kernel.onChange(peis::Pattern(), [&](const peis::Tuple& t) { record(t, false); });
  const auto onDelete =
      kernel.onDelete(peis::Pattern(), [&](const peis::Tuple& t) { record(t, true); });
  for (const auto& p : patterns) kernel.subscribe(p);
  if (duration > 0)
    kernel.after(std::chrono::milliseconds(static_cast<long long>(duration * 1000)),
                 [&kernel] { kernel.quit("--duration reached"); });
  std::cerr << "peis-record: PEIS " << kernel.id() << " records " << patternText << " into "
            << *output << std::endl;

  const std::string reason = kernel.run();
  kernel.removeCallback(onChange);
  kernel.removeCallback(onDelete);
  // A callback running now ends before the writer stops.
  std::promise<void> idle;
  kernel.post([&idle] { idle.set_value(); });
  idle.get_future().wait();
  const peis::Timestamp ended = peis::systemNow();
  try {
    writer->finish({{"ended", micros(ended)}});
  } catch (const peis::Error& e) {
    std::cerr << "peis-record: " << e.what() << "\n";
    return 1;
  }
  const auto stats = writer->stats();
  const double seconds = static_cast<double>((ended - started).count()) / 1e6;
  std::cerr << "peis-record: " << reason << "; " << stats.written << " events (" << changes.load()
            << " changes, " << deletions.load() << " deletions) in " << seconds << " s into "
            << *output << ", dropped " << stats.dropped << ", " << stats.commits
            << " commits, the longest " << stats.longestCommit.count() / 1000.0 << " ms"
            << std::endl;
  return reason.rfind("cannot write", 0) == 0 ? 1 : 0;
}
