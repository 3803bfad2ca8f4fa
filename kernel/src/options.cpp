// Parsing and checking of the --peis-* flags.
#include "peis/options.h"

#include <charconv>
#include <cstdlib>
#include <cstring>

#include "peis/error.h"
#include "peis/key.h"

namespace peis {
namespace {

[[noreturn]] void bad(const std::string& flag, const std::string& why) {
  throw Error(ErrorCode::InvalidArgument, flag + ": " + why + " (see --help)");
}

std::uint64_t parseUnsigned(const std::string& flag, std::string_view text, std::uint64_t max) {
  std::uint64_t value = 0;
  const auto* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || value > max) {
    bad(flag, "'" + std::string(text) + "' is not a number in 0.." + std::to_string(max));
  }
  return value;
}

void checkEcology(const std::string& source, std::string_view name) {
  if (name.empty() || name.size() > kMaxNameBytes) {
    bad(source, "the ecology name must be 1.." + std::to_string(kMaxNameBytes) + " bytes");
  }
  for (char c : name) {
    if (static_cast<unsigned char>(c) <= 0x20 || static_cast<unsigned char>(c) >= 0x7f) {
      bad(source, "the ecology name may only hold printable characters");
    }
  }
}

}  // namespace

std::pair<std::string, std::uint16_t> parseHostPort(std::string_view text) {
  const auto colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0 || colon + 1 == text.size()) {
    bad("--peis-connect", "'" + std::string(text) + "' is not HOST:PORT");
  }
  auto host = text.substr(0, colon);
  if (host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  const auto port = parseUnsigned("--peis-connect", text.substr(colon + 1), 65535);
  if (port == 0 || host.empty())
    bad("--peis-connect", "'" + std::string(text) + "' is not HOST:PORT");
  return {std::string(host), static_cast<std::uint16_t>(port)};
}

namespace {

// The settings that come from the environment as well as from a flag: the
// ones an ecology shares (as ROS_DOMAIN_ID is shared), never the ones that
// single out one process (id, name, port, set-tuple), which every program
// started from a shell would otherwise inherit and clash on.
struct EnvironmentSetting {
  const char* variable;
  const char* flag;
};
constexpr EnvironmentSetting kEnvironmentSettings[] = {
    {"PEIS_ECOLOGY", "--peis-ecology"},
    {"PEIS_CONNECT", "--peis-connect"},
    {"PEIS_DISCOVERY_PORT", "--peis-discovery-port"},
    {"PEIS_LIVENESS_MS", "--peis-liveness-ms"},
    {"PEIS_MAX_DATA", "--peis-max-data"},
    {"PEIS_CREDENTIALS", "--peis-credentials"},
    {"PEIS_POLICY", "--peis-policy"},
};

// The --peis-max-* and --peis-quota-* flags: counts and byte sizes, 1..kMaxLimit.
constexpr std::uint64_t kMaxLimit = std::uint64_t{1} << 40;
struct SizeLimitFlag {
  const char* flag;
  std::size_t Limits::*field;
};
constexpr SizeLimitFlag kSizeLimitFlags[] = {
    {"--peis-max-connections", &Limits::maxConnections},
    {"--peis-max-handshakes-per-host", &Limits::maxHandshakesPerHost},
    {"--peis-max-routes", &Limits::maxRoutes},
    {"--peis-max-held-bytes", &Limits::maxHeldBytes},
    {"--peis-quota-keys", &Limits::quotaKeys},
    {"--peis-quota-bytes", &Limits::quotaBytes},
    {"--peis-quota-total-keys", &Limits::quotaTotalKeys},
    {"--peis-quota-total-bytes", &Limits::quotaTotalBytes},
};

std::size_t* sizeLimit(Limits& limits, std::string_view flag) {
  for (const auto& known : kSizeLimitFlags) {
    if (flag == known.flag) return &(limits.*known.field);
  }
  return nullptr;
}

// Applies one setting of a value-taking flag; `source` names where the value
// came from (the flag, or the environment variable) for the error message.
// False when `flag` is not a value-taking flag.
bool applySetting(Options& options, const std::string& flag, const std::string& source,
                  const std::string& value) {
  if (flag == "--peis-id") {
    const auto id = parsePeisId(value);
    if (!id) bad(source, "'" + value + "' is not an id in 1.." + std::to_string(kMaxPeisId));
    options.id = *id;
  } else if (flag == "--peis-name") {
    options.name = value;
    if (auto problem = nameProblem(options.name)) bad(source, *problem);
  } else if (flag == "--peis-port") {
    options.port = static_cast<std::uint16_t>(parseUnsigned(source, value, 65535));
  } else if (flag == "--peis-connect") {
    options.connect.push_back(value);
    try {
      parseHostPort(value);
    } catch (const Error&) {
      if (source == flag) throw;
      bad(source, "'" + value + "' is not HOST:PORT");
    }
  } else if (flag == "--peis-set-tuple") {
    const auto eq = value.find('=');
    if (eq == std::string::npos) bad(source, "'" + value + "' is not KEY=VALUE");
    options.setTuples.emplace_back(value.substr(0, eq), value.substr(eq + 1));
    if (auto problem = keyProblem(options.setTuples.back().first)) bad(source, *problem);
  } else if (flag == "--peis-ecology") {
    options.ecology = value;
    checkEcology(source, options.ecology);
  } else if (flag == "--peis-discovery-port") {
    options.discoveryPort = static_cast<std::uint16_t>(parseUnsigned(source, value, 65535));
    if (options.discoveryPort == 0) bad(source, "port 0 is not a port");
  } else if (flag == "--peis-liveness-ms") {
    const auto ms = parseUnsigned(source, value, 3600000);
    if (ms < 100) bad(source, "at least 100 ms");
    options.liveness = std::chrono::milliseconds(ms);
  } else if (flag == "--peis-max-data") {
    options.maxDataBytes = parseUnsigned(source, value, kMaxDataBytes);
  } else if (flag == "--peis-handshake-ms") {
    const auto ms = parseUnsigned(source, value, 3600000);
    if (ms < 100) bad(source, "at least 100 ms");
    options.limits.handshake = std::chrono::milliseconds(ms);
  } else if (flag == "--peis-credentials") {
    if (value.empty()) bad(source, "needs a file");
    options.credentials = value;
  } else if (flag == "--peis-policy") {
    if (value.empty()) bad(source, "needs a file");
    options.policy = value;
  } else if (flag == "--peis-id-claim-ms") {
    options.limits.idClaimWindow = std::chrono::milliseconds(parseUnsigned(source, value, 3600000));
  } else if (flag == "--peis-relay-grace-ms") {
    options.limits.relayGrace = std::chrono::milliseconds(parseUnsigned(source, value, 60000));
  } else if (auto* limit = sizeLimit(options.limits, flag)) {
    *limit = parseUnsigned(source, value, kMaxLimit);
    if (*limit == 0) bad(source, "at least 1");
  } else {
    return false;
  }
  return true;
}

// "a:1, b:2 c:3" -> {"a:1", "b:2", "c:3"}: commas or white space between.
std::vector<std::string> splitList(std::string_view text) {
  std::vector<std::string> items;
  std::string item;
  for (char c : text) {
    if (c == ',' || c == ' ' || c == '\t' || c == '\n') {
      if (!item.empty()) items.push_back(std::move(item));
      item.clear();
    } else {
      item += c;
    }
  }
  if (!item.empty()) items.push_back(std::move(item));
  return items;
}

}  // namespace

Options Options::fromEnvironment() {
  Options options;
  for (const auto& setting : kEnvironmentSettings) {
    const char* value = std::getenv(setting.variable);
    if (!value || !*value) continue;  // set but empty: as if unset
    if (std::string_view(setting.flag) == "--peis-connect") {
      for (const auto& target : splitList(value)) {
        applySetting(options, setting.flag, setting.variable, target);
      }
    } else {
      applySetting(options, setting.flag, setting.variable, value);
    }
  }
  return options;
}

Options Options::fromArgs(int& argc, char** argv) {
  Options options = fromEnvironment();
  bool connectFromFlags = false;  // the first --peis-connect replaces PEIS_CONNECT's list
  if (argc > 0 && argv[0]) {
    std::string program = argv[0];
    const auto slash = program.rfind('/');
    options.programName = slash == std::string::npos ? program : program.substr(slash + 1);
  }
  int out = 1;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--") {  // everything after belongs to the program
      for (; i < argc; ++i) argv[out++] = argv[i];
      break;
    }
    if (arg == "--help" || arg == "-h") options.help = true;
    if (arg.rfind("--peis-", 0) != 0) {
      argv[out++] = argv[i];
      continue;
    }
    std::string flag = arg, value;
    bool hasValue = false;
    if (const auto eq = arg.find('='); eq != std::string::npos) {
      flag = arg.substr(0, eq);
      value = arg.substr(eq + 1);
      hasValue = true;
    }
    if (flag == "--peis-no-discovery") {
      if (hasValue) bad(flag, "takes no value");
      options.discovery = false;
      continue;
    }
    if (!isValueFlag(flag)) bad(flag, "unknown PEIS option");
    if (!hasValue) {
      if (i + 1 >= argc) bad(flag, "needs a value");
      value = argv[++i];
    }
    if (flag == "--peis-connect" && !connectFromFlags) {
      options.connect.clear();
      connectFromFlags = true;
    }
    applySetting(options, flag, flag, value);
  }
  argc = out;
  argv[out] = nullptr;
  return options;
}

bool Options::isValueFlag(std::string_view flag) {
  for (const char* known :
       {"--peis-id", "--peis-name", "--peis-port", "--peis-connect", "--peis-set-tuple",
        "--peis-ecology", "--peis-discovery-port", "--peis-liveness-ms", "--peis-max-data",
        "--peis-handshake-ms", "--peis-id-claim-ms", "--peis-relay-grace-ms", "--peis-credentials",
        "--peis-policy"}) {
    if (flag == known) return true;
  }
  for (const auto& known : kSizeLimitFlags) {
    if (flag == known.flag) return true;
  }
  return false;
}

void Options::validate() const {
  if (id && !isValidPeisId(*id)) bad("--peis-id", std::to_string(*id) + " is out of range");
  if (!name.empty()) {
    if (auto problem = nameProblem(name)) bad("--peis-name", *problem);
  }
  for (const auto& target : connect) parseHostPort(target);
  for (const auto& [key, value] : setTuples) {
    if (auto problem = keyProblem(key)) bad("--peis-set-tuple", *problem);
  }
  checkEcology("--peis-ecology", ecology);
  if (!policy.empty() && credentials.empty()) {
    bad("--peis-policy",
        "a policy needs --peis-credentials (an open ecology authenticates "
        "nobody, so no policy could tell its PEIS apart)");
  }
  if (maxDataBytes > kMaxDataBytes) bad("--peis-max-data", "at most 2^31-1 bytes");
  if (liveness.count() < 100 || liveness.count() > 3600000) {
    bad("--peis-liveness-ms", "100..3600000 ms");
  }
  if (limits.handshake.count() < 100 || limits.handshake.count() > 3600000) {
    bad("--peis-handshake-ms", "100..3600000 ms");
  }
  if (limits.idClaimWindow.count() < 0 || limits.idClaimWindow.count() > 3600000) {
    bad("--peis-id-claim-ms", "0..3600000 ms");
  }
  if (limits.relayGrace.count() < 0 || limits.relayGrace.count() > 60000) {
    bad("--peis-relay-grace-ms", "0..60000 ms");
  }
  for (const auto& known : kSizeLimitFlags) {
    const auto value = limits.*known.field;
    if (value == 0 || value > kMaxLimit) bad(known.flag, "1..2^40");
  }
  // Both travel as u32 milliseconds (a Write's wait, a Subscribe's lease).
  constexpr std::int64_t kMostMs = 0xffffffff;
  if (writeTimeout.count() <= 0 || writeTimeout.count() > kMostMs) {
    bad("writeTimeout", "1..4294967295 ms");
  }
  if (subscriptionLease.count() < 300 || subscriptionLease.count() > kMostMs) {
    bad("subscriptionLease", "300..4294967295 ms");
  }
}

std::string Options::helpText() {
  return "PEIS options:\n"
         "  --peis-id N              this PEIS's id, 1..2147483647 (default: random)\n"
         "  --peis-name NAME         this PEIS's name, published as kernel.name\n"
         "                           (default: the program name)\n"
         "  --peis-port P            TCP port to listen on (default: any free)\n"
         "  --peis-connect HOST:PORT open a link to another PEIS (repeatable)\n"
         "  --peis-set-tuple KEY=VALUE  set an own tuple at start (repeatable)\n"
         "  --peis-ecology NAME      the ecology to join (default: default)\n"
         "  --peis-no-discovery      do not look for other PEIS on the LAN\n"
         "  --peis-discovery-port P  UDP port of the discovery beacons (default 7700)\n"
         "  --peis-liveness-ms MS    a link silent this long is dead (default 2000)\n"
         "  --peis-max-data BYTES    largest tuple data accepted (default 64 MiB)\n"
         "  --peis-credentials FILE  join the secured ecology these credentials are for\n"
         "                           (authenticated, encrypted links; docs/security.md)\n"
         "  --peis-policy FILE       who may do what with this PEIS's tuples (YAML; with\n"
         "                           --peis-credentials; default: members all but kernel.*)\n"
         "Limits against misbehaving peers (docs/security.md):\n"
         "  --peis-handshake-ms MS   close a connection not through its handshake by then\n"
         "                           (default 5000)\n"
         "  --peis-max-connections N connections open at once (default 256)\n"
         "  --peis-max-handshakes-per-host N  connections of one address in their\n"
         "                           handshake (default 16)\n"
         "  --peis-max-routes N      PEIS in the routing table, and routes one\n"
         "                           neighbour may advertise (default 4096)\n"
         "  --peis-max-held-bytes B  frames waiting for their source's route (default 4 MiB)\n"
         "  --peis-quota-keys N      keys one remote writer may hold here (default 1024)\n"
         "  --peis-quota-bytes B     data bytes one remote writer may hold here (default 64 MiB)\n"
         "  --peis-quota-total-keys N   ... all remote writers together (default 8192)\n"
         "  --peis-quota-total-bytes B  ... all remote writers together (default 256 MiB)\n"
         "  --peis-id-claim-ms MS    how long after start this PEIS gives its id up to an\n"
         "                           earlier holder (default 10000)\n"
         "  --peis-relay-grace-ms MS how long a PEIS's frames still come the old way after\n"
         "                           its route changed (default 2000)\n"
         "  --help, -h               show this help\n"
         "Environment (a flag wins over its variable):\n"
         "  PEIS_ECOLOGY NAME        as --peis-ecology\n"
         "  PEIS_CONNECT LIST        as --peis-connect, HOST:PORT separated by , or space\n"
         "  PEIS_DISCOVERY_PORT P    as --peis-discovery-port\n"
         "  PEIS_LIVENESS_MS MS      as --peis-liveness-ms\n"
         "  PEIS_MAX_DATA BYTES      as --peis-max-data\n"
         "  PEIS_CREDENTIALS FILE    as --peis-credentials\n"
         "  PEIS_POLICY FILE         as --peis-policy\n"
         "  PEIS_DISCOVERY_SCOPE     off | loopback | lan (default lan)\n"
         "  PEIS_LOG LEVEL           quiet | warn | info | debug (default info)\n";
}

}  // namespace peis
