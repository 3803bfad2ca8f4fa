// Options of one PEIS: the --peis-* command-line flags, or a struct filled
// in code. Parsing removes the flags it knows from argv and leaves the rest
// to the program. The settings an ecology shares also come from the
// environment (PEIS_ECOLOGY, PEIS_CONNECT, PEIS_DISCOVERY_PORT,
// PEIS_LIVENESS_MS, PEIS_MAX_DATA); a flag wins over its variable.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "peis/types.h"

namespace peis {

struct Options {
  std::optional<PeisId> id;          // --peis-id N (picked at random when absent)
  std::string name;                  // --peis-name NAME (default: program name)
  std::uint16_t port = 0;            // --peis-port P (0: pick a free one)
  std::vector<std::string> connect;  // --peis-connect HOST:PORT, repeatable
  std::vector<std::pair<std::string, std::string>> setTuples;  // --peis-set-tuple KEY=VALUE
  std::string ecology = "default";                             // --peis-ecology NAME
  bool discovery = true;                                       // --peis-no-discovery turns it off
  std::size_t maxDataBytes = kDefaultMaxDataBytes;             // --peis-max-data BYTES
  std::uint16_t discoveryPort = 7700;                 // --peis-discovery-port P (UDP beacons)
  std::chrono::milliseconds liveness{2000};           // --peis-liveness-ms: silence => gone
  std::chrono::milliseconds writeTimeout{5000};       // a remote write's deadline
  std::chrono::milliseconds subscriptionLease{6000};  // renewed every third of it
  bool network = true;                                // false: a PEIS on its own, no sockets at all
  bool tool = false;  // a short-lived tool PEIS (the `peis` CLI): peers list it as PeerInfo::tool
  bool help = false;  // --help or -h was given (left in argv)
  std::string programName;  // basename of argv[0]

  // The defaults with the PEIS_* environment variables applied. Throws
  // Error(InvalidArgument) naming the variable and what is wrong.
  static Options fromEnvironment();
  // fromEnvironment(), then parses and removes the --peis-* flags from argv
  // (argc is updated); a flag wins over its variable (a --peis-connect flag
  // replaces PEIS_CONNECT's list). Throws Error(InvalidArgument) naming the
  // flag or variable and what is wrong.
  static Options fromArgs(int& argc, char** argv);
  // True for the --peis-* flags that take a value ("--peis-id", ...), so a
  // program can skip a flag's value when it scans argv itself.
  static bool isValueFlag(std::string_view flag);
  // Checks the values of a struct filled in code; throws like fromArgs.
  void validate() const;
  // The help text of the --peis-* flags.
  static std::string helpText();
};

// "host:port" or "[v6]:port" -> (host, port); throws Error(InvalidArgument).
std::pair<std::string, std::uint16_t> parseHostPort(std::string_view text);

}  // namespace peis
