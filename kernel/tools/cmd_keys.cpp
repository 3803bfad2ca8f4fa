// peis keys: the credentials of a secured ecology (docs/security.md). Runs
// no PEIS: it writes the trust root and the credentials files, through the
// kernel's public credentials API (peis/credentials.h), so the tool links
// nothing more than the kernel does.
#include <iostream>

#include "command.h"
#include "peis/credentials.h"

namespace peis::cli {
namespace {

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> items;
  std::string item;
  for (char c : text + ",") {
    if (c == ',') {
      if (!item.empty()) items.push_back(item);
      item.clear();
    } else if (c != ' ') {
      item += c;
    }
  }
  return items;
}

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

void print(const CredentialsInfo& info) {
  std::cout << "credentials " << info.file << "\n"
            << "  ecology    " << info.ecology << " (root " << info.rootFingerprint << ")\n"
            << "  principal  " << info.principal << "\n"
            << "  groups     " << (info.groups.empty() ? "-" : joined(info.groups)) << "\n"
            << "  names      " << joined(info.names) << "\n";
  if (info.pinnedId != 0) std::cout << "  id         " << info.pinnedId << "\n";
  std::cout << "  valid      " << info.issued << " to "
            << (info.expires.empty() ? std::string("never expires") : info.expires) << "\n"
            << "  serial     " << info.serial << "\n"
            << "  key        " << info.keyFingerprint << "\n";
}

int run(const Options& options, const Args& args) {
  if (args.positional.empty()) throw UsageError("keys needs init, add, radio or show");
  const auto& verb = args.positional[0];
  const auto dir = args.text("--dir").value_or("peis-keys");
  if (verb == "init") {
    expectArguments(args, 1, 2, "init [ECOLOGY]");
    const auto ecology = args.positional.size() == 2 ? args.positional[1] : options.ecology;
    const auto root = createTrustRoot(dir, ecology);
    std::cout << "trust root of the secured ecology '" << root.ecology << "' in " << root.file
              << " (fingerprint " << root.fingerprint << ")\n"
              << "Keep it secret. Issue credentials with: peis keys add NAME\n";
    return 0;
  }
  if (verb == "add") {
    expectArguments(args, 2, 2, "add NAME");
    CredentialsRequest request;
    request.principal = args.positional[1];
    if (auto groups = args.text("--group")) request.groups = splitList(*groups);
    if (auto names = args.text("--names")) request.names = splitList(*names);
    if (auto id = args.number("--id")) request.pinnedId = static_cast<PeisId>(*id);
    if (auto days = args.number("--days")) request.validDays = static_cast<int>(*days);
    request.file = args.text("--out").value_or("");
    request.replace = args.has("--force");
    print(issueCredentials(dir, request));
    std::cout << "A PEIS joins with --peis-credentials FILE or PEIS_CREDENTIALS=FILE.\n";
    return 0;
  }
  if (verb == "radio") {
    if (args.positional.size() < 2) throw UsageError("keys radio needs the tiny node ids");
    std::vector<int> nodes;
    for (std::size_t i = 1; i < args.positional.size(); ++i) {
      const auto& text = args.positional[i];
      if (text.empty() || text.size() > 5 || text.find_first_not_of("0123456789") != text.npos) {
        throw UsageError("keys radio: '" + text + "' is not a tiny node id");
      }
      nodes.push_back(std::stoi(text));
    }
    const auto info = createRadioKeys(dir, nodes, args.has("--force"));
    std::cout << "radio keys in " << info.file << " (peis-tinybridge --radio-keys " << info.file
              << ")\n";
    for (const auto& [node, key] : info.nodeKeys) {
      std::cout << "  node " << node << ": TINY_KEY=" << key
                << " TINY_TRUST=65534:" << info.bridgeKey << ":w\n";
    }
    return 0;
  }
  if (verb == "show") {
    expectArguments(args, 2, 2, "show FILE");
    print(readCredentialsInfo(args.positional[1]));
    return 0;
  }
  throw UsageError("keys: '" + verb + "' is not init, add, radio or show");
}

}  // namespace

Command keysCommand() {
  Command c{"keys",
            "keys init [ECOLOGY] | keys add NAME | keys radio ID... | keys show FILE",
            "the credentials of a secured ecology (runs no PEIS)",
            "A secured ecology in three commands (docs/security.md):\n"
            "  peis keys init home        the trust root, in peis-keys/root.key\n"
            "  peis keys add home --names '*' --group admin\n"
            "                             one credentials file for every PEIS\n"
            "  export PEIS_CREDENTIALS=$PWD/peis-keys/home.cred\n"
            "Every PEIS started with those credentials joins the ecology 'home' over\n"
            "authenticated, encrypted links; PEIS without them are refused. Finer\n"
            "rules: credentials per PEIS or group, and a policy (--peis-policy).\n"
            "  init [ECOLOGY]  creates DIR/root.key (ECOLOGY: default --peis-ecology)\n"
            "  add NAME        issues DIR/NAME.cred for the principal NAME, whose PEIS\n"
            "                  are named NAME unless --names says more\n"
            "  radio ID...     DIR/radio.yaml: keys for a secured tiny radio (the\n"
            "                  tinybridge's --radio-keys) and each node's TINY_KEY\n"
            "  show FILE       what a credentials file says",
            {"--dir", "--group", "--names", "--id", "--days", "--out", "--force"},
            true,
            nullptr};
  c.runAlone = run;
  return c;
}

}  // namespace peis::cli
