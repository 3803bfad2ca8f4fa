// peis: the command-line tool of the ecology. Each subcommand runs a short-
// lived PEIS of its own that joins the ecology, does one thing and leaves:
// ls, node, get, set, watch, tuples, meta. See `peis --help`.
#include <peis/peis.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const char* kUsage =
    "Usage: peis COMMAND [ARGS] [--json] [--peis-* options]\n"
    "\n"
    "Commands:\n"
    "  ls                          the PEIS of the ecology: id, name, host, hops, links, up-time\n"
    "  node                        run a plain PEIS until killed or kernel.do-quit = yes\n"
    "  get OWNER.KEY [--wait S]    print a tuple's value; exit 1 if absent at the deadline\n"
    "  set OWNER.KEY VALUE         write a tuple; exit 0 once its owner accepted it\n"
    "                              (put -- before a VALUE that starts with -)\n"
    "  watch PATTERN [--count N] [--timeout S]\n"
    "                              one line per change: OWNER.KEY = VALUE\n"
    "  tuples [PATTERN]            the current tuples of the ecology that match\n"
    "  meta OWNER.METAKEY TARGET_OWNER.TARGET_KEY\n"
    "                              point a meta tuple at a tuple\n"
    "\n"
    "OWNER is a PEIS id or name; in patterns also *. Keys may use * (one part)\n"
    "and a trailing ** (the rest). Exit status: 0 done, 1 not found / not\n"
    "accepted / deadline, 2 bad usage.\n"
    "\n";

struct Args {
  std::string command;
  std::vector<std::string> positional;
  bool json = false;
  bool help = false;
  double wait = -1;
  double timeout = -1;
  long count = -1;
};

[[noreturn]] void usageError(const std::string& message) {
  std::cerr << "peis: " << message << " (see peis --help)\n";
  std::exit(2);
}

double parseSeconds(const std::string& flag, const std::string& text) {
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used != text.size() || value < 0 || value > 86400) throw std::invalid_argument(text);
    return value;
  } catch (const std::exception&) {
    usageError(flag + " needs a number of seconds, not '" + text + "'");
  }
}

Args parseArgs(int argc, char** argv) {
  Args args;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usageError(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--json") {
      args.json = true;
    } else if (arg == "--help" || arg == "-h") {
      args.help = true;
    } else if (arg == "--wait") {
      args.wait = parseSeconds(arg, value());
    } else if (arg == "--timeout") {
      args.timeout = parseSeconds(arg, value());
    } else if (arg == "--count") {
      const auto text = value();
      try {
        args.count = std::stol(text);
      } catch (const std::exception&) {
        usageError("--count needs a number, not '" + text + "'");
      }
      if (args.count < 1) usageError("--count must be at least 1");
    } else if (arg == "--") {  // the rest are values, even if they start with '-'
      for (++i; i < argc; ++i) {
        (args.command.empty() ? args.command : args.positional.emplace_back()) = argv[i];
      }
    } else if (arg.size() > 1 && arg[0] == '-' &&
               !std::isdigit(static_cast<unsigned char>(arg[1]))) {
      usageError("unknown option " + arg);
    } else if (args.command.empty()) {
      args.command = arg;
    } else {
      args.positional.push_back(arg);
    }
  }
  return args;
}

std::string jsonString(std::string_view text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
          out += buffer;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

std::string printable(const peis::Tuple& t) {
  if (t.encoding == peis::Encoding::Binary) return "<" + std::to_string(t.data.size()) + " bytes>";
  return t.data;
}

std::string tupleJson(const peis::Tuple& t) {
  auto micros = [](peis::Timestamp ts) { return std::to_string(ts.time_since_epoch().count()); };
  return "{\"owner\":" + std::to_string(t.owner) + ",\"key\":" + jsonString(t.key) +
         ",\"data\":" + jsonString(t.data) + ",\"creator\":" + std::to_string(t.creator) +
         ",\"mimetype\":" + jsonString(t.mimetype) +
         ",\"encoding\":" + (t.encoding == peis::Encoding::Binary ? "\"binary\"" : "\"ascii\"") +
         ",\"seqno\":" + std::to_string(t.seqno) + ",\"ts_write\":" + micros(t.ts_write) +
         ",\"ts_user\":" + micros(t.ts_user) + ",\"ts_expire\":" + micros(t.ts_expire) + "}";
}

bool waitUntil(const std::function<bool()>& condition, Clock::time_point deadline) {
  while (!condition()) {
    if (Clock::now() >= deadline) return condition();
    std::this_thread::sleep_for(2ms);
  }
  return true;
}

// Waits for the first other PEIS (discovery answers within milliseconds, but
// a loaded host may be slower), then until the membership has been stable for
// a moment; never past the deadline.
void settle(peis::Kernel& kernel, Clock::time_point deadline) {
  while (kernel.peers().size() < 2 && Clock::now() < deadline) std::this_thread::sleep_for(5ms);
  auto last = kernel.peers().size();
  auto stableSince = Clock::now();
  while (Clock::now() < deadline && Clock::now() - stableSince < 300ms) {
    std::this_thread::sleep_for(10ms);
    const auto now = kernel.peers().size();
    if (now != last) {
      last = now;
      stableSince = Clock::now();
    }
  }
}

peis::PeisId resolveOwnerWaiting(peis::Kernel& kernel, const std::string& owner,
                                 Clock::time_point deadline) {
  if (auto id = peis::parsePeisId(owner)) return *id;
  peis::validateName(owner);
  while (true) {
    try {
      return kernel.resolveOwner(owner);
    } catch (const peis::Error& e) {
      if (e.code() != peis::ErrorCode::NotFound || Clock::now() >= deadline) throw;
    }
    std::this_thread::sleep_for(5ms);
  }
}

bool reachable(peis::Kernel& kernel, peis::PeisId id) {
  for (const auto& peer : kernel.peers()) {
    if (peer.id == id) return true;
  }
  return false;
}

int commandGet(peis::Kernel& kernel, const Args& args) {
  if (args.positional.size() != 1) usageError("get needs OWNER.KEY");
  const auto name = peis::parseFullName(args.positional[0]);
  const auto wait =
      std::chrono::milliseconds(static_cast<long>((args.wait < 0 ? 2.0 : args.wait) * 1000));
  const auto deadline = Clock::now() + wait;
  const auto owner = resolveOwnerWaiting(kernel, name.owner, deadline);
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  auto tuple = kernel.get(owner, name.key, std::max(left, 1ms));
  if (!tuple) {
    std::cerr << "peis: " << peis::fullName(owner, name.key) << " has no value"
              << (reachable(kernel, owner) ? "" : " (PEIS not reachable)") << "\n";
    return 1;
  }
  std::cout << (args.json ? tupleJson(*tuple) : printable(*tuple)) << "\n";
  return 0;
}

int commandSet(peis::Kernel& kernel, const Args& args) {
  if (args.positional.size() != 2) usageError("set needs OWNER.KEY VALUE");
  const auto name = peis::parseFullName(args.positional[0]);
  const auto deadline =
      Clock::now() +
      std::chrono::milliseconds(static_cast<long>((args.timeout < 0 ? 5.0 : args.timeout) * 1000));
  const auto owner = resolveOwnerWaiting(kernel, name.owner, deadline);
  if (!waitUntil([&] { return reachable(kernel, owner); }, deadline)) {
    std::cerr << "peis: PEIS " << owner << " is not reachable\n";
    return 1;
  }
  const auto tuple = kernel.set(owner, name.key, args.positional[1]);
  if (args.json) {
    std::cout << "{\"owner\":" << owner << ",\"key\":" << jsonString(name.key)
              << ",\"seqno\":" << tuple.seqno << "}\n";
  }
  return 0;
}

int commandMeta(peis::Kernel& kernel, const Args& args) {
  if (args.positional.size() != 2) usageError("meta needs OWNER.METAKEY TARGET_OWNER.TARGET_KEY");
  const auto meta = peis::parseFullName(args.positional[0]);
  const auto target = peis::parseFullName(args.positional[1]);
  const auto deadline = Clock::now() + 5s;
  const auto metaOwner = resolveOwnerWaiting(kernel, meta.owner, deadline);
  const auto targetOwner = resolveOwnerWaiting(kernel, target.owner, deadline);
  if (!waitUntil([&] { return reachable(kernel, metaOwner); }, deadline)) {
    std::cerr << "peis: PEIS " << metaOwner << " is not reachable\n";
    return 1;
  }
  kernel.setMeta(metaOwner, meta.key, targetOwner, target.key);
  if (args.json) {
    std::cout << "{\"meta\":" << jsonString(peis::fullName(metaOwner, meta.key))
              << ",\"target\":" << jsonString(peis::fullName(targetOwner, target.key)) << "}\n";
  }
  return 0;
}

peis::Pattern patternOf(peis::Kernel& kernel, const std::string& text) {
  const auto dot = text.find('.');
  if (dot == std::string::npos) usageError("'" + text + "' is not OWNER.KEYPATTERN");
  const auto owner = text.substr(0, dot);
  if (owner == "*") return peis::Pattern(text.substr(dot + 1));
  return peis::Pattern(text.substr(dot + 1), resolveOwnerWaiting(kernel, owner, Clock::now() + 3s));
}

int commandWatch(peis::Kernel& kernel, const Args& args) {
  if (args.positional.size() != 1) usageError("watch needs PATTERN");
  const auto pattern = patternOf(kernel, args.positional[0]);
  std::mutex mu;
  long seen = 0;
  std::atomic<bool> done{false};
  kernel.onChange(pattern, [&](const peis::Tuple& t) {
    if (t.owner == kernel.id()) return;  // this tool's own kernel tuples
    std::lock_guard lock(mu);
    if (done) return;
    std::cout << (args.json ? tupleJson(t) : t.fullName() + " = " + printable(t)) << std::endl;
    if (args.count > 0 && ++seen >= args.count) {
      done = true;
      kernel.quit("count reached");
    }
  });
  kernel.subscribe(pattern);
  if (args.timeout >= 0) {
    const bool quit =
        kernel.runFor(std::chrono::milliseconds(static_cast<long>(args.timeout * 1000)));
    std::lock_guard lock(mu);
    done = true;
    return quit || args.count < 0 ? 0 : 1;
  }
  kernel.run();
  return 0;
}

int commandTuples(peis::Kernel& kernel, const Args& args) {
  const auto deadline =
      Clock::now() +
      std::chrono::milliseconds(static_cast<long>((args.wait < 0 ? 3.0 : args.wait) * 1000));
  settle(kernel, deadline);
  const auto pattern = patternOf(kernel, args.positional.empty() ? "*.**" : args.positional[0]);
  if (args.positional.size() > 1) usageError("tuples takes at most one PATTERN");
  kernel.subscribe(pattern);
  kernel.subscribe(peis::Pattern("kernel.all-keys"));
  // Done when every reachable PEIS's matching keys (per its kernel.all-keys)
  // are here, and the owner the pattern names (if any) is reachable.
  auto complete = [&] {
    if (pattern.ownerFilter() && !reachable(kernel, *pattern.ownerFilter())) return false;
    for (const auto& peer : kernel.peers()) {
      if (peer.id == kernel.id() || (pattern.ownerFilter() && *pattern.ownerFilter() != peer.id)) {
        continue;
      }
      auto keys = kernel.get(peer.id, "kernel.all-keys");
      if (!keys) return false;
      std::size_t start = 0;
      const auto& list = keys->data;
      while (start < list.size()) {
        auto end = list.find(' ', start);
        if (end == std::string::npos) end = list.size();
        const auto key = list.substr(start, end - start);
        if (key != "kernel.all-keys" && pattern.matchesOwnerAndKey(peer.id, key) &&
            !kernel.get(peer.id, key)) {
          return false;
        }
        start = end + 1;
      }
    }
    return true;
  };
  if (!waitUntil(complete, deadline)) std::cerr << "peis: some tuples did not arrive in time\n";
  auto tuples = kernel.find(pattern);
  tuples.erase(std::remove_if(tuples.begin(), tuples.end(),
                              [&](const peis::Tuple& t) { return t.owner == kernel.id(); }),
               tuples.end());
  if (args.json) {
    std::cout << "[";
    for (std::size_t i = 0; i < tuples.size(); ++i)
      std::cout << (i ? "," : "") << tupleJson(tuples[i]);
    std::cout << "]\n";
  } else {
    for (const auto& t : tuples) std::cout << t.fullName() << " = " << printable(t) << "\n";
  }
  return 0;
}

int commandLs(peis::Kernel& kernel, const Args& args) {
  const auto deadline =
      Clock::now() +
      std::chrono::milliseconds(static_cast<long>((args.wait < 0 ? 2.0 : args.wait) * 1000));
  settle(kernel, deadline);
  kernel.subscribe(peis::Pattern("kernel.*"));
  const auto peers = kernel.peers();
  waitUntil(
      [&] {
        for (const auto& peer : peers) {
          if (peer.id != kernel.id() && !kernel.get(peer.id, "kernel.links")) return false;
        }
        return true;
      },
      deadline);
  // PEIS that left while we waited (e.g. short-lived `peis` commands) are
  // not listed.
  std::set<peis::PeisId> stillThere;
  for (const auto& peer : kernel.peers()) stillThere.insert(peer.id);
  const auto now = peis::systemNow().time_since_epoch().count();
  auto value = [&](peis::PeisId id, const char* key) {
    auto t = kernel.get(id, key);
    return t ? t->data : std::string("?");
  };
  if (args.json) std::cout << "[";
  bool first = true;
  if (!args.json)
    std::printf("%-11s %-20s %-16s %4s  %-24s %s\n", "ID", "NAME", "HOST", "HOPS", "LINKS", "UP");
  for (const auto& peer : peers) {
    if (peer.id == kernel.id() || !stillThere.count(peer.id)) continue;
    const auto started = value(peer.id, "kernel.started");
    double up = -1;
    try {
      up = static_cast<double>(now - std::stoll(started)) / 1e6;
    } catch (const std::exception&) {
    }
    if (args.json) {
      std::cout << (first ? "" : ",") << "{\"id\":" << peer.id
                << ",\"name\":" << jsonString(peer.name)
                << ",\"host\":" << jsonString(value(peer.id, "kernel.hostname"))
                << ",\"hops\":" << peer.hops
                << ",\"links\":" << jsonString(value(peer.id, "kernel.links"))
                << ",\"uptime_s\":" << up << "}";
    } else {
      char upText[32] = "?";
      if (up >= 0) std::snprintf(upText, sizeof upText, "%.1fs", up);
      std::printf("%-11d %-20s %-16s %4d  %-24s %s\n", peer.id, peer.name.c_str(),
                  value(peer.id, "kernel.hostname").c_str(), peer.hops,
                  value(peer.id, "kernel.links").c_str(), upText);
    }
    first = false;
  }
  if (args.json) std::cout << "]\n";
  return 0;
}

int commandNode(peis::Kernel& kernel, const Args&) {
  // One write per line: the kernel thread logs to stderr at the same time,
  // and scripts parse this line.
  std::cerr << ("peis node: PEIS " + std::to_string(kernel.id()) + " '" + kernel.name() +
                "' on port " + std::to_string(kernel.port()) + "\n");
  const auto reason = kernel.run();
  std::cerr << ("peis node: " + reason + "\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  peis::Options options;
  try {
    options = peis::Options::fromArgs(argc, argv);
  } catch (const peis::Error& e) {
    std::cerr << "peis: " << e.what() << "\n";
    return 2;
  }
  const auto args = parseArgs(argc, argv);
  if (args.help || args.command.empty() || args.command == "help") {
    std::cout << kUsage << peis::Options::helpText();
    return args.command.empty() && !args.help ? 2 : 0;
  }
  static const std::set<std::string> commands{"ls",    "node",   "get", "set",
                                              "watch", "tuples", "meta"};
  if (!commands.count(args.command)) usageError("unknown command '" + args.command + "'");
  if (options.name.empty()) options.name = args.command == "node" ? "node" : "peis-" + args.command;
  try {
    peis::Kernel kernel(options);
    if (args.command == "ls") return commandLs(kernel, args);
    if (args.command == "node") return commandNode(kernel, args);
    if (args.command == "get") return commandGet(kernel, args);
    if (args.command == "set") return commandSet(kernel, args);
    if (args.command == "watch") return commandWatch(kernel, args);
    if (args.command == "tuples") return commandTuples(kernel, args);
    return commandMeta(kernel, args);
  } catch (const peis::Error& e) {
    std::cerr << "peis: " << e.what() << "\n";
    return e.code() == peis::ErrorCode::InvalidArgument ||
                   e.code() == peis::ErrorCode::InvalidKey ||
                   e.code() == peis::ErrorCode::InvalidName
               ? 2
               : 1;
  }
}
