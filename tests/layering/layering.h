// The layering check: every source file's #include lines against the table
// of docs/architecture.md (between <!-- layering:begin --> and
// <!-- layering:end -->), which says per folder which of our folders and
// which outside libraries it may include. Pure functions over an in-memory
// tree, so the rules themselves are unit-tested; layering_main.cpp reads the
// repository and runs them.
#pragma once

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace peis::layering {

// One row: files under any of `folders` may include their own row's files,
// files under `ours` (folders ending in '/', or single files) and outside
// headers of the categories in `outside` (lower case: c, c++, system, boost,
// yaml-cpp, sqlite, catch2, eigen, opencv, simavr, avr-libc).
struct Rule {
  std::vector<std::string> folders;
  std::vector<std::string> ours;
  std::set<std::string> outside;
  int line = 0;  // in the markdown file
};

// A malformed table: the message names the line.
struct RulesError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The rows of the table between the markers. Throws RulesError when the
// markers are missing, a row is malformed, or a category is unknown.
std::vector<Rule> parseRules(std::string_view markdown);

struct Include {
  std::string name;  // as written between the quotes or brackets
  bool angled = false;
  int line = 0;
};

// The literal #include lines of a C or C++ source (computed includes are
// skipped: they cannot be checked).
std::vector<Include> includesOf(std::string_view source);

// The category of a header that is not ours ("c", "c++", "system", ...).
std::string categoryOf(const Include& include);

// path (relative to the root, '/'-separated) -> contents.
using SourceTree = std::map<std::string, std::string>;

// The files of the tree an include may name: for "x.h", x.h beside the
// including file, else every file whose path ends in /x.h; for <x.h>, files
// in a public include folder (a path ending in include/x.h). Empty: the
// header is not ours.
std::vector<std::string> resolve(const SourceTree& tree, const std::string& from,
                                 const Include& include);

// The row whose folder is the longest prefix of `path`, or nullptr.
const Rule* ruleFor(const std::vector<Rule>& rules, const std::string& path);

struct Violation {
  std::string file;
  int line = 0;
  std::string message;
};

// Every include of every file checked against its row; a file under no row
// is a violation too (a new folder needs a row). When an include names
// several files, one in the row's own folders is taken; otherwise every one
// of them must be allowed (the check does not know the include path).
std::vector<Violation> check(const std::vector<Rule>& rules, const SourceTree& tree);

// Whether a path is a C or C++ source or header that the check reads.
bool isSource(std::string_view path);

}  // namespace peis::layering
