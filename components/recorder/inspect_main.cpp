// peis-inspect (`peis inspect FILE.db`): what a recording holds — who
// recorded what and when, whether it ended cleanly, totals, rates and one
// line per tuple. No ecology is joined. docs/operating.md.
#include <peis/error.h>

#include <iostream>

#include "recorder/inspect_report.h"
#include "recorder/program_args.h"
#include "recorder/recording_reader.h"

namespace {

const char* kUsage = R"usage(Usage: peis-inspect FILE.db [--json]
       peis inspect FILE.db [--json]

Prints what a recording of `peis record` holds: the patterns, the ecology,
host and PEIS that recorded it, the time span and whether the recorder
stopped cleanly, the number of changes and deletions, rates and bytes, and
one line per tuple (changes, deletions, rate, bytes, first and last
arrival in seconds from the start). Exit status 1 when FILE.db is not a
readable recording, 2 for bad usage.

Options:
  --json    one JSON object instead of the text
  --help    this text
)usage";

}  // namespace

int main(int argc, char** argv) {
  peis::recorder::ProgramArgs args;
  try {
    args = peis::recorder::parseProgramArgs(argc, argv, {}, {"--json"});
  } catch (const std::invalid_argument& e) {
    std::cerr << "peis-inspect: " << e.what() << " (see --help)\n";
    return 2;
  }
  if (args.help) {
    std::cout << kUsage;
    return 0;
  }
  if (args.positional.size() != 1) {
    std::cerr << "peis-inspect: give one FILE.db (see --help)\n";
    return 2;
  }
  const std::string& path = args.positional[0];
  try {
    peis::recorder::RecordingReader reader(path);
    const auto summary = reader.summary();
    std::cout << (args.has("--json") ? peis::recorder::inspectJson(summary, path) + "\n"
                                     : peis::recorder::inspectText(summary, path));
  } catch (const peis::Error& e) {
    std::cerr << "peis-inspect: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
