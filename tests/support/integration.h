// Test helper for the multi-process tests: `peis` processes (nodes and
// one-shot commands) in an ecology of their own, in-process Kernels' options,
// small readers of their state, and REQUIRE_WAIT, which fails with a report
// of the state the test describes (StateReport).
#pragma once

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "peis/kernel.h"
#include "support/process.h"
#include "support/wait_for.h"

namespace peis::test {

using namespace std::chrono_literals;

inline constexpr auto kDeadline = std::chrono::milliseconds(20s);

// A PEIS process's id and TCP port, from the line `peis node` prints at start.
struct NodeInfo {
  peis::PeisId id = 0;
  std::uint16_t port = 0;
};

inline std::optional<NodeInfo> parseNodeLine(const std::string& text) {
  static const std::regex line(R"(peis node: PEIS (\d+) '[^']*' on port (\d+))");
  std::smatch match;
  if (!std::regex_search(text, match, line)) return std::nullopt;
  return NodeInfo{static_cast<peis::PeisId>(std::stol(match[1])),
                  static_cast<std::uint16_t>(std::stoul(match[2]))};
}

// Starts `peis node` in `ecology` with extra flags.
inline std::unique_ptr<Process> startNode(const std::string& ecology,
                                          std::vector<std::string> flags = {}) {
  flags.insert(flags.begin(), "node");
  // The tests read the nodes' log lines, whatever PEIS_LOG the caller has.
  return std::make_unique<Process>(cliArgs(ecology, std::move(flags)),
                                   Process::Environment{{"PEIS_LOG", "info"}});
}

// Waits for a node's start line; fails the test if it never comes.
inline NodeInfo awaitNode(Process& node) {
  std::optional<NodeInfo> info;
  waitFor(
      [&] {
        info = parseNodeLine(node.err());
        return info.has_value() || !node.running();
      },
      kDeadline);
  INFO(node.describe());
  REQUIRE(info.has_value());
  return *info;
}

struct CliResult {
  int status = -1;
  std::string out, err;
};

// Runs one `peis` command to its end.
inline CliResult runCli(const std::string& ecology, std::vector<std::string> args,
                        std::chrono::milliseconds deadline = std::chrono::milliseconds(30s)) {
  Process cli(cliArgs(ecology, std::move(args)));
  const auto status = cli.wait(deadline);
  INFO(cli.describe());
  REQUIRE(status.has_value());
  return CliResult{*status, cli.out(), cli.err()};
}

inline std::string describe(const CliResult& r) {
  return "exit " + std::to_string(r.status) + "\n--- stdout ---\n" + r.out + "\n--- stderr ---\n" +
         r.err;
}

inline peis::Options kernelOptions(const std::string& ecology, const std::string& name,
                                   bool discovery = true, std::vector<std::string> connect = {}) {
  peis::Options o;
  o.ecology = ecology;
  o.name = name;
  o.discovery = discovery;
  o.connect = std::move(connect);
  return o;
}

inline std::string localhost(std::uint16_t port) { return "127.0.0.1:" + std::to_string(port); }

inline std::optional<peis::PeerInfo> peerOf(const peis::Kernel& k, peis::PeisId id) {
  for (const auto& peer : k.peers()) {
    if (peer.id == id) return peer;
  }
  return std::nullopt;
}

inline bool hasPeer(const peis::Kernel& k, peis::PeisId id) { return peerOf(k, id).has_value(); }

inline std::string valueOf(const peis::Kernel& k, peis::PeisId owner, const std::string& key) {
  auto tuple = k.get(owner, key);
  return tuple ? tuple->data : "<absent>";
}

inline std::string peersText(const peis::Kernel& k) {
  std::string text;
  for (const auto& peer : k.peers()) {
    text += std::to_string(peer.id) + "'" + peer.name + "'@" + std::to_string(peer.hops) + " ";
  }
  return text;
}

inline std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> result;
  for (std::string word; in >> word;) result.push_back(word);
  return result;
}

inline bool listContains(const std::string& list, peis::PeisId id) {
  const auto all = words(list);
  return std::find(all.begin(), all.end(), std::to_string(id)) != all.end();
}

inline std::vector<std::string> lines(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> result;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) result.push_back(line);
  }
  return result;
}

inline peis::PeisId randomId() {
  std::random_device device;
  return std::uniform_int_distribution<peis::PeisId>(1000, peis::kMaxPeisId)(device);
}

// What a test's PEIS look like now, for the message of a failed wait; set
// for the scope of a StateReport.
inline std::function<std::string()>* currentReport = nullptr;

class StateReport {
 public:
  explicit StateReport(std::function<std::string()> fn)
      : fn_(std::move(fn)), previous_(currentReport) {
    currentReport = &fn_;
  }
  StateReport(const StateReport&) = delete;
  StateReport& operator=(const StateReport&) = delete;
  ~StateReport() { currentReport = previous_; }

 private:
  std::function<std::string()> fn_;
  std::function<std::string()>* previous_;
};

inline std::string reportState() { return currentReport ? (*currentReport)() : std::string(); }

// REQUIRE_WAIT(condition[, deadline]): waits like waitFor; if the condition
// never held, fails with the state the current StateReport describes then.
#define REQUIRE_WAIT(...)                                      \
  do {                                                         \
    const bool held_ = peis::test::waitFor(__VA_ARGS__);       \
    INFO((held_ ? std::string() : peis::test::reportState())); \
    REQUIRE(held_);                                            \
  } while (false)

// Records what a callback sees, for checks from the test thread.
class Recorder {
 public:
  void add(std::string entry) {
    std::lock_guard lock(mu_);
    entries_.push_back(std::move(entry));
  }
  bool contains(const std::string& entry) const {
    std::lock_guard lock(mu_);
    return std::find(entries_.begin(), entries_.end(), entry) != entries_.end();
  }
  std::vector<std::string> entries() const {
    std::lock_guard lock(mu_);
    return entries_;
  }
  std::string text() const {
    std::string all;
    for (const auto& e : entries()) all += e + "\n";
    return all;
  }

 private:
  mutable std::mutex mu_;
  std::vector<std::string> entries_;
};

}  // namespace peis::test
