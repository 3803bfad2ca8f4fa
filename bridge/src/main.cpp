// peis-tinybridge: puts the tiny nodes on one radio into the ecology as
// ordinary PEIS (see tiny_bridge.h and docs/tinybridge.md).
#include <signal.h>

#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>

#include "peis/error.h"
#include "peis/options.h"
#include "tiny_bridge.h"
#include "tiny_timing.h"

namespace {

peis::bridge::TinyBridge* running = nullptr;

void onSignal(int) {
  if (running != nullptr) running->stop();
}

std::string usage() {
  return "Usage: peis-tinybridge --link LINK [--keys SEED.yaml] [--registry FILE] [options]\n"
         "\n"
         "A full PEIS that makes the tiny nodes on one radio ordinary PEIS of the ecology:\n"
         "each node gets a proxy PEIS with its own id; full PEIS read, set, watch and\n"
         "subscribe to its tuples, and its subscriptions to full PEIS tuples are served.\n"
         "\n"
         "  --link LINK          the radio: medium:PORT[:SLOTS] (the simulated medium\n"
         "                       on 127.0.0.1, tiny/medium), unix:PATH (a serial line on a UNIX\n"
         "                       socket, e.g. an emulated MCU's UART) or /dev/DEVICE[:BAUD]\n"
         "  --keys FILE          YAML seed of the key registry (keys: NAME: INDEX,\n"
         "                       nodes: ID: NAME); applied at every start\n"
         "  --registry FILE      the SQLite key registry (default tinybridge-keys.sqlite);\n"
         "                       an index never changes once given\n"
         "  --tiny-id N          the bridge's node id on the radio (default 65534)\n"
         "  --node-timeout-ms N  a node not heard for this long leaves (default " +
         std::to_string(TINY_NODE_TIMEOUT_MS) +
         ")\n"
         "  --write-timeout-ms N a write a node did not confirm by then fails (default " +
         std::to_string(TINY_WRITE_DEADLINE_MS) +
         ")\n"
         "  --radio-keys FILE    secures the radio (docs/security.md): the bridge's key\n"
         "                       and one per node it vouches for (YAML, secret); frames\n"
         "                       of other nodes, unsecured, forged or replayed are dropped\n"
         "  --max-unregistered-nodes N  on an open radio, proxies for nodes the seed\n"
         "                       does not name, at most (default 16)\n"
         "  --help               this text\n"
         "\n"
         "Environment: TINY_LOSS, TINY_DUP, TINY_DELAY_MS, TINY_JITTER_MS shape the\n"
         "simulated medium as for the nodes; PEIS_LOG=quiet|warn|info|debug.\n";
}

bool number(const char* text, unsigned long max, unsigned long* out) {
  if (text == nullptr || *text == '\0') return false;
  char* end = nullptr;
  errno = 0;
  const unsigned long value = std::strtoul(text, &end, 10);
  if (errno != 0 || *end != '\0' || value > max || text[0] == '-') return false;
  *out = value;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  peis::bridge::BridgeConfig config;
  config.registryPath = "tinybridge-keys.sqlite";
  try {
    config.peis = peis::Options::fromArgs(argc, argv);
    if (config.peis.name.empty() || config.peis.name == config.peis.programName)
      config.peis.name = "tinybridge";
  } catch (const peis::Error& e) {
    std::cerr << "peis-tinybridge: " << e.what() << "\n";
    return 2;
  }
  if (config.peis.help) {
    std::cout << usage() << "\n" << peis::Options::helpText();
    return 0;
  }
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const char* value = i + 1 < argc ? argv[i + 1] : nullptr;
    unsigned long n = 0;
    auto bad = [&](const std::string& why) {
      std::cerr << "peis-tinybridge: " << arg << ": " << why << " (see --help)\n";
      return 2;
    };
    if (arg == "--link" && value != nullptr) {
      config.link = value;
    } else if (arg == "--keys" && value != nullptr) {
      config.seedPath = value;
    } else if (arg == "--registry" && value != nullptr) {
      config.registryPath = value;
    } else if (arg == "--tiny-id" && value != nullptr) {
      if (!number(value, 0xFFFE, &n) || n == 0) return bad("takes 1..65534");
      config.tinyId = static_cast<std::uint16_t>(n);
    } else if (arg == "--node-timeout-ms" && value != nullptr) {
      if (!number(value, 3600000, &n) || n < 100) return bad("takes 100..3600000");
      config.nodeTimeout = std::chrono::milliseconds(n);
    } else if (arg == "--write-timeout-ms" && value != nullptr) {
      if (!number(value, 3600000, &n) || n < 10) return bad("takes 10..3600000");
      config.writeDeadline = std::chrono::milliseconds(n);
    } else if (arg == "--radio-keys" && value != nullptr) {
      config.radioKeysPath = value;
    } else if (arg == "--max-unregistered-nodes" && value != nullptr) {
      if (!number(value, 65534, &n)) return bad("takes 0..65534");
      config.maxUnregisteredNodes = n;
    } else {
      return bad(value == nullptr && arg.rfind("--", 0) == 0 ? "needs a value or is unknown"
                                                             : "unknown argument");
    }
    ++i;
  }
  if (config.link.empty()) {
    std::cerr << "peis-tinybridge: --link is required (see --help)\n";
    return 2;
  }
  try {
    peis::bridge::TinyBridge bridge(config);
    running = &bridge;
    struct sigaction sa {};
    sa.sa_handler = onSignal;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    std::cerr << "peis-tinybridge: PEIS " << bridge.kernel().id() << " '" << bridge.kernel().name()
              << "' on port " << bridge.kernel().port() << std::endl;
    const auto why = bridge.run();
    running = nullptr;
    const auto s = bridge.stats();
    std::cerr << "peis-tinybridge: " << why << "; frames in " << s.framesIn << " out "
              << s.framesOut << " dropped " << s.framesDropped << ", mirrored " << s.tuplesMirrored
              << " stale " << s.tuplesStale << ", forwarded " << s.tuplesForwarded << " unmappable "
              << s.forwardUnmappable << ", writes sent " << s.writesSent << " confirmed "
              << s.writesConfirmed << " failed " << s.writesFailed << " refused " << s.writesRefused
              << ", nodes joined " << s.nodesJoined << " left " << s.nodesLeft << " refused "
              << s.nodesRefused << ", frames refused " << s.framesRefused << ", forged tuples "
              << s.tuplesForged << std::endl;
    return 0;
  } catch (const peis::Error& e) {
    std::cerr << "peis-tinybridge: " << e.what() << "\n";
    return 1;
  }
}
