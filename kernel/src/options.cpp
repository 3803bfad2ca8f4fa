// Parsing and checking of the --peis-* flags.
#include "peis/options.h"

#include <charconv>
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

void checkEcology(std::string_view name) {
  if (name.empty() || name.size() > kMaxNameBytes) {
    bad("--peis-ecology",
        "the ecology name must be 1.." + std::to_string(kMaxNameBytes) + " bytes");
  }
  for (char c : name) {
    if (static_cast<unsigned char>(c) <= 0x20 || static_cast<unsigned char>(c) >= 0x7f) {
      bad("--peis-ecology", "the ecology name may only hold printable characters");
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

Options Options::fromArgs(int& argc, char** argv) {
  Options options;
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
    auto needValue = [&]() -> std::string {
      if (hasValue) return value;
      if (i + 1 >= argc) bad(flag, "needs a value");
      return argv[++i];
    };
    if (flag == "--peis-id") {
      const auto text = needValue();
      const auto id = parsePeisId(text);
      if (!id) bad(flag, "'" + text + "' is not an id in 1.." + std::to_string(kMaxPeisId));
      options.id = *id;
    } else if (flag == "--peis-name") {
      options.name = needValue();
      if (auto problem = nameProblem(options.name)) bad(flag, *problem);
    } else if (flag == "--peis-port") {
      options.port = static_cast<std::uint16_t>(parseUnsigned(flag, needValue(), 65535));
    } else if (flag == "--peis-connect") {
      options.connect.push_back(needValue());
      parseHostPort(options.connect.back());
    } else if (flag == "--peis-set-tuple") {
      const auto text = needValue();
      const auto eq = text.find('=');
      if (eq == std::string::npos) bad(flag, "'" + text + "' is not KEY=VALUE");
      options.setTuples.emplace_back(text.substr(0, eq), text.substr(eq + 1));
      if (auto problem = keyProblem(options.setTuples.back().first)) bad(flag, *problem);
    } else if (flag == "--peis-ecology") {
      options.ecology = needValue();
      checkEcology(options.ecology);
    } else if (flag == "--peis-no-discovery") {
      if (hasValue) bad(flag, "takes no value");
      options.discovery = false;
    } else if (flag == "--peis-discovery-port") {
      options.discoveryPort = static_cast<std::uint16_t>(parseUnsigned(flag, needValue(), 65535));
      if (options.discoveryPort == 0) bad(flag, "port 0 is not a port");
    } else if (flag == "--peis-liveness-ms") {
      const auto ms = parseUnsigned(flag, needValue(), 3600000);
      if (ms < 100) bad(flag, "at least 100 ms");
      options.liveness = std::chrono::milliseconds(ms);
    } else if (flag == "--peis-max-data") {
      options.maxDataBytes = parseUnsigned(flag, needValue(), kMaxDataBytes);
    } else {
      bad(flag, "unknown PEIS option");
    }
  }
  argc = out;
  argv[out] = nullptr;
  return options;
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
  checkEcology(ecology);
  if (maxDataBytes > kMaxDataBytes) bad("--peis-max-data", "at most 2^31-1 bytes");
  if (liveness.count() < 100 || liveness.count() > 3600000) {
    bad("--peis-liveness-ms", "100..3600000 ms");
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
         "  --help, -h               show this help\n";
}

}  // namespace peis
