// peis ls: the PEIS of the ecology, one line each.
#include <cstdio>
#include <iostream>
#include <set>

#include "command.h"
#include "lookup.h"
#include "output.h"

namespace peis::cli {
namespace {

int run(Kernel& kernel, const Args& args) {
  expectArguments(args, 0, 0, "no arguments");
  const bool json = args.has("--json");
  const auto deadline = deadlineIn(args.seconds("--wait").value_or(2.0));
  settle(kernel, deadline);
  kernel.subscribe(Pattern("kernel.*"));
  const auto peers = listedPeers(kernel.peers(), kernel.id(), args.has("--all"));
  waitUntil(
      [&] {
        for (const auto& peer : peers) {
          if (!kernel.get(peer.id, special::kLinks)) return false;
        }
        return true;
      },
      deadline);
  // PEIS that left while we waited (e.g. short-lived `peis` commands) are
  // not listed.
  std::set<PeisId> stillThere;
  for (const auto& peer : kernel.peers()) stillThere.insert(peer.id);
  const auto now = systemNow().time_since_epoch().count();
  auto value = [&](PeisId id, const char* key) {
    auto t = kernel.get(id, key);
    return t ? t->data : std::string("?");
  };
  if (json) {
    std::cout << "[";
  } else {
    std::printf("%-11s %-20s %-16s %4s  %-24s %s\n", "ID", "NAME", "HOST", "HOPS", "LINKS", "UP");
  }
  bool first = true;
  for (const auto& peer : peers) {
    if (!stillThere.count(peer.id)) continue;
    double up = -1;
    try {
      up = static_cast<double>(now - std::stoll(value(peer.id, special::kStarted))) / 1e6;
    } catch (const std::exception&) {
    }
    if (json) {
      std::cout << (first ? "" : ",") << "{\"id\":" << peer.id
                << ",\"name\":" << json::quote(peer.name)
                << ",\"host\":" << json::quote(value(peer.id, special::kHostname))
                << ",\"hops\":" << peer.hops
                << ",\"links\":" << json::quote(value(peer.id, special::kLinks))
                << ",\"uptime_s\":" << up << ",\"tool\":" << (peer.tool ? "true" : "false") << "}";
    } else {
      std::printf("%-11d %-20s %-16s %4d  %-24s %s%s\n", peer.id, peer.name.c_str(),
                  value(peer.id, special::kHostname).c_str(), peer.hops,
                  value(peer.id, special::kLinks).c_str(), seconds(up).c_str(),
                  peer.tool ? "  (tool)" : "");
    }
    first = false;
  }
  if (json) std::cout << "]\n";
  return 0;
}

}  // namespace

Command lsCommand() {
  return {"ls",
          "ls",
          "the PEIS of the ecology: id, name, host, hops, links, up-time",
          "Waits until the membership settled (at most --wait, 2 s), then lists\n"
          "every other PEIS. Short-lived tool PEIS (other `peis` commands) are left\n"
          "out unless --all.",
          {"--all", "--wait", "--json"},
          true,
          run};
}

}  // namespace peis::cli
