// Options of one PEIS: the --peis-* command-line flags, or a struct filled
// in code. Parsing removes the flags it knows from argv and leaves the rest
// to the program. The settings an ecology shares also come from the
// environment (PEIS_ECOLOGY, PEIS_CONNECT, PEIS_DISCOVERY_PORT,
// PEIS_LIVENESS_MS, PEIS_MAX_DATA, PEIS_CREDENTIALS, PEIS_POLICY); a flag
// wins over its variable.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "peis/types.h"

namespace peis {

// Limits that keep a PEIS serving when peers misbehave: each is counted
// (NetworkStats, Kernel::accessStats) and logged when hit. They hold in open
// and secured ecologies alike (docs/security.md, "Limits").
struct Limits {
  // A connection that has not completed its handshake by then is closed.
  std::chrono::milliseconds handshake{5000};  // --peis-handshake-ms
  // Connections open at once (in their handshake or established); more are
  // closed as they are accepted.
  std::size_t maxConnections = 256;  // --peis-max-connections
  // Connections from one address still in their handshake.
  std::size_t maxHandshakesPerHost = 16;  // --peis-max-handshakes-per-host
  // PEIS in the routing table, and route entries one neighbour may advertise.
  std::size_t maxRoutes = 4096;  // --peis-max-routes
  // Bytes of routed frames waiting for their source's route (at most 1024
  // frames in any case).
  std::size_t maxHeldBytes = 4u << 20;  // --peis-max-held-bytes
  // Keys and data bytes one remote writer may hold in this PEIS (the tuples
  // whose current value it wrote), and all remote writers together.
  std::size_t quotaKeys = 1024;              // --peis-quota-keys
  std::size_t quotaBytes = 64u << 20;        // --peis-quota-bytes
  std::size_t quotaTotalKeys = 8192;         // --peis-quota-total-keys
  std::size_t quotaTotalBytes = 256u << 20;  // --peis-quota-total-bytes
  // How long after its start a PEIS still gives its id up to a PEIS that
  // claims it and says it started earlier (an earlier holder is found in
  // that time); later it keeps its id and refuses the claim.
  std::chrono::milliseconds idClaimWindow{10000};  // --peis-id-claim-ms
  // How long after a route changes (a link to its PEIS came up, its next hop
  // moved) that PEIS's frames are still taken the way they came before:
  // frames sent while the routes changed. In that time a neighbour offering
  // a route to it could forge them (docs/security.md).
  std::chrono::milliseconds relayGrace{2000};  // --peis-relay-grace-ms
};

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
  Limits limits;  // --peis-handshake-ms, --peis-max-*, --peis-quota-*, --peis-id-claim-ms,
                  // --peis-relay-grace-ms
  // A credentials file of a secured ecology (docs/security.md): the PEIS
  // joins that ecology only, over authenticated and encrypted links.
  std::string credentials;  // --peis-credentials FILE (PEIS_CREDENTIALS)
  // Who may do what with this PEIS's tuples (YAML, docs/security.md); only
  // with credentials. Without it, a secured PEIS takes the default policy.
  std::string policy;  // --peis-policy FILE (PEIS_POLICY)
  bool tool = false;   // a short-lived tool PEIS (the `peis` CLI): peers list it as PeerInfo::tool
  bool help = false;   // --help or -h was given (left in argv)
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
