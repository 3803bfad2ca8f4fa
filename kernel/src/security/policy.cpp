// Policies: reading and asking them; see policy.h.
#include "security/policy.h"

#include <charconv>

#include "peis/error.h"
#include "peis/key.h"
#include "security/yaml_file.h"

namespace peis::security {

namespace {

constexpr const char* kOpKeys[] = {"read", "write", "append", "delete"};

std::vector<std::string> split(std::string_view key) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const auto dot = key.find('.', start);
    parts.emplace_back(key.substr(start, dot == std::string_view::npos ? dot : dot - start));
    if (dot == std::string_view::npos) break;
    start = dot + 1;
  }
  return parts;
}

const char* kDefaultText =
    "# The default policy of a secured PEIS (docs/security.md): every member\n"
    "# reads and writes every tuple but kernel.*; group admin also writes\n"
    "# kernel.* (kernel.do-quit, kernel.policy).\n"
    "admin: [group:admin]\n"
    "rules:\n"
    "  - who: ['*']\n"
    "    read: ['**']\n"
    "    write: ['**']\n"
    "    append: ['**']\n"
    "    delete: ['**']\n"
    "  - who: [group:admin]\n"
    "    write: ['kernel.**']\n"
    "    append: ['kernel.**']\n"
    "    delete: ['kernel.**']\n";

}  // namespace

Subject subjectOf(const Certificate& certificate, PeisId id, const std::string& name) {
  return Subject{id, name, certificate.principal, certificate.groups, certificate.serial};
}

const char* Policy::opName(Op op) {
  switch (op) {
    case Op::Read:
      return "read";
    case Op::Write:
      return "set";
    case Op::Append:
      return "append to";
    case Op::Delete:
      return "delete";
  }
  return "?";
}

bool Policy::Who::matches(const Subject& s) const {
  switch (kind) {
    case Kind::Anyone:
      return true;
    case Kind::Id:
      return s.id == id;
    case Kind::Principal:
      return s.principal == text;
    case Kind::Group:
      for (const auto& g : s.groups) {
        if (g == text) return true;
      }
      return false;
    case Kind::Name:
      if (!text.empty() && text.back() == '*') {
        return std::string_view(s.name).substr(0, text.size() - 1) ==
               std::string_view(text).substr(0, text.size() - 1);
      }
      return s.name == text;
  }
  return false;
}

// Walks the key's parts in place (no copies: this runs for every value an
// owner sends a subscriber of a secured ecology).
bool Policy::keyMatches(const std::vector<std::string>& pattern, std::string_view key) {
  std::size_t at = 0;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    const auto& p = pattern[i];
    if (at > key.size()) return false;  // no part left
    if (p == "**") return true;         // one or more parts left (at <= size)
    const auto dot = key.find('.', at);
    const auto part =
        key.substr(at, dot == std::string_view::npos ? std::string_view::npos : dot - at);
    at = dot == std::string_view::npos ? key.size() + 1 : dot + 1;
    if (p == "*") continue;
    if (p.back() == '*') {
      if (part.substr(0, p.size() - 1) != std::string_view(p).substr(0, p.size() - 1)) {
        return false;
      }
      continue;
    }
    if (p != part) return false;
  }
  return at > key.size();  // every part matched
}

bool Policy::allows(const Subject& who, Op op, std::string_view key) const {
  const bool kernelKey = key.rfind("kernel.", 0) == 0;
  for (const auto& rule : rules_) {
    bool named = false;
    for (const auto& w : rule.who) named |= w.matches(who);
    if (!named) continue;
    for (const auto& pattern : rule.patterns[static_cast<int>(op)]) {
      // Writes of kernel.* need a pattern that names kernel first.
      if (kernelKey && op != Op::Read && pattern.front() != "kernel") continue;
      if (keyMatches(pattern, key)) return true;
    }
  }
  return false;
}

bool Policy::isAdmin(const Subject& who) const {
  for (const auto& w : admins_) {
    if (w.matches(who)) return true;
  }
  return false;
}

std::optional<std::string> Policy::revoked(const Subject& who) const {
  for (const auto serial : revokedSerials_) {
    if (serial == who.serial) {
      return "its credentials (serial " + serialText(serial) + ") are revoked";
    }
  }
  for (const auto& principal : revokedPrincipals_) {
    if (principal == who.principal) return "principal '" + principal + "' is revoked";
  }
  return std::nullopt;
}

Policy Policy::defaults() { return parse(kDefaultText, "the default policy"); }

Policy Policy::load(const std::string& file) { return parse(readTextFile(file), file); }

Policy Policy::parse(std::string_view text, const std::string& origin) {
  YamlFile yaml(origin);
  const auto root = yaml.parse(text);
  Policy policy;
  policy.text_ = std::string(text);
  if (!root.isDefined() || root.isNull()) yaml.fail(root, "an empty policy");
  yaml.onlyKeys(root, {"admin", "rules", "revoked"}, "a policy");

  auto readWho = [&](const YamlNode& node, const std::string& what) {
    Who w;
    const auto text = yaml.text(node, what);
    if (text == "*") return w;
    const auto colon = text.find(':');
    const auto kind = text.substr(0, colon == std::string::npos ? 0 : colon);
    const auto value = colon == std::string::npos ? std::string() : text.substr(colon + 1);
    if (kind == "name") {
      w.kind = Who::Kind::Name;
      const auto bare =
          !value.empty() && value.back() == '*' ? value.substr(0, value.size() - 1) : value;
      if (bare.empty() ? value != "*" : nameProblem(bare).has_value()) {
        yaml.fail(node, what + ": '" + value + "' is not a PEIS name (or a prefix ending in *)");
      }
    } else if (kind == "id") {
      w.kind = Who::Kind::Id;
      const auto id = parsePeisId(value);
      if (!id) yaml.fail(node, what + ": '" + value + "' is not a PEIS id");
      w.id = *id;
    } else if (kind == "principal" || kind == "group") {
      w.kind = kind == "group" ? Who::Kind::Group : Who::Kind::Principal;
      if (nameProblem(value)) yaml.fail(node, what + ": '" + value + "' is not a " + kind);
    } else {
      yaml.fail(node,
                what + ": '" + text + "' is none of '*', name:NAME, id:N, principal:P, group:G");
    }
    w.text = value;
    return w;
  };
  auto readList = [&](const YamlNode& node, const std::string& what) {
    if (!node.isSequence()) yaml.fail(node, what + " must be a list");
    return node.items;
  };

  if (const auto admin = root["admin"]) {
    for (const auto& item : readList(admin, "admin"))
      policy.admins_.push_back(readWho(item, "admin"));
  } else {
    policy.admins_.push_back(Who{Who::Kind::Group, "admin", 0});
  }
  if (const auto rules = root["rules"]) {
    for (const auto& node : readList(rules, "rules")) {
      yaml.onlyKeys(node, {"who", "read", "write", "append", "delete"}, "a rule");
      Rule rule;
      for (const auto& item : readList(yaml.required(node, "who", "a rule"), "who")) {
        rule.who.push_back(readWho(item, "who"));
      }
      for (int op = 0; op < 4; ++op) {
        const auto list = node[kOpKeys[op]];
        if (!list) continue;
        for (const auto& item : readList(list, kOpKeys[op])) {
          const auto pattern = yaml.text(item, kOpKeys[op]);
          auto parts = split(pattern);
          for (std::size_t i = 0; i < parts.size(); ++i) {
            const auto& p = parts[i];
            const auto bare = !p.empty() && p.back() == '*' ? p.substr(0, p.size() - 1) : p;
            const bool ok = p == "*" || (p == "**" && i + 1 == parts.size()) ||
                            (!bare.empty() && !keyProblem(bare));
            if (!ok) {
              yaml.fail(item, "'" + pattern +
                                  "' is not a key pattern (parts: a key part, *, a prefix "
                                  "ending in *, or ** last)");
            }
          }
          rule.patterns[op].push_back(std::move(parts));
        }
      }
      policy.rules_.push_back(std::move(rule));
    }
  }
  if (const auto revoked = root["revoked"]) {
    for (const auto& item : readList(revoked, "revoked")) {
      const auto text = yaml.text(item, "revoked");
      if (text.rfind("principal:", 0) == 0) {
        policy.revokedPrincipals_.push_back(text.substr(10));
        continue;
      }
      std::uint64_t serial = 0;
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), serial, 16);
      if (ec != std::errc() || end != text.data() + text.size() || text.size() != 16) {
        yaml.fail(item,
                  "revoked: '" + text + "' is neither a serial (16 hex digits) nor principal:P");
      }
      policy.revokedSerials_.push_back(serial);
    }
  }
  return policy;
}

}  // namespace peis::security
