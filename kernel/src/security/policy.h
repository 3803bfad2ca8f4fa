// Policy: who may do what with one PEIS's tuples in a secured ecology
// (docs/security.md, "Authorization"). Read from YAML — a file given with
// --peis-policy, or the kernel.policy tuple an administrator writes at run
// time — and asked by the owner, the one place every remote write and
// subscription of its tuples passes:
//
//   admin: [group:admin]          # who may replace it at run time
//   rules:
//     - who: [group:devices, name:lamp, id:17, principal:configurator]
//       read: ["**"]              # subscribe and read
//       write: ["light.*", "mi-*"]  # remote set; kernel.* only when named
//       append: []
//       delete: []
//   revoked: [589ad529400d4ffa, principal:mallory]
//
// A key pattern is dotted; a part `*` is any one part, a part ending in `*`
// a prefix ("mi-*"), a last part `**` one or more parts. A principal is
// allowed what any rule whose `who` names it allows; nothing else. Writes
// (set, append, delete) of kernel.* keys need a pattern that names
// `kernel` as its first part. Without a policy, members of the ecology may
// read and write everything but kernel.*, which only group admin writes.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "peis/types.h"
#include "security/certificate.h"

namespace peis::security {

// Who is asking: what the PEIS proved in its handshake.
struct Subject {
  PeisId id = 0;
  std::string name;       // its PEIS name
  std::string principal;  // its credentials'
  std::vector<std::string> groups;
  std::uint64_t serial = 0;  // its certificate's
};
Subject subjectOf(const Certificate& certificate, PeisId id, const std::string& name);

class Policy {
 public:
  enum class Op { Read, Write, Append, Delete };

  // Members may read and write everything but kernel.*; group admin may
  // also write kernel.* and replace the policy.
  static Policy defaults();
  // Parses the YAML `text`; throws Error(InvalidConfig) naming
  // `origin:line` and the problem.
  static Policy parse(std::string_view text, const std::string& origin);
  // Reads and parses a policy file.
  static Policy load(const std::string& file);

  bool allows(const Subject& who, Op op, std::string_view key) const;
  bool isAdmin(const Subject& who) const;
  // Why the credentials of `who` are revoked, if they are.
  std::optional<std::string> revoked(const Subject& who) const;
  // The text it came from (published as kernel.policy).
  const std::string& text() const { return text_; }

  static const char* opName(Op op);

 private:
  struct Who {
    enum class Kind { Anyone, Name, Id, Principal, Group } kind = Kind::Anyone;
    std::string text;  // a name may end in '*' (a prefix)
    PeisId id = 0;
    bool matches(const Subject& s) const;
  };
  struct Rule {
    std::vector<Who> who;
    std::vector<std::vector<std::string>> patterns[4];  // per Op, each split into parts
  };
  static bool keyMatches(const std::vector<std::string>& pattern, std::string_view key);

  std::vector<Rule> rules_;
  std::vector<Who> admins_;
  std::vector<std::uint64_t> revokedSerials_;
  std::vector<std::string> revokedPrincipals_;
  std::string text_;
};

}  // namespace peis::security
