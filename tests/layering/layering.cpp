// The layering check's rules (see layering.h).
#include "layering.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <sstream>

namespace peis::layering {
namespace {

constexpr std::string_view kBegin = "<!-- layering:begin -->";
constexpr std::string_view kEnd = "<!-- layering:end -->";

const std::set<std::string> kCategories = {
    "c",      "c++",    "system",   "boost",      "yaml-cpp", "sqlite",    "catch2",    "eigen",
    "opencv", "simavr", "avr-libc", "cyclonedds", "zeromq",   "libsodium", "libgcrypt", "ipsec-mb"};

// The C standard library's headers (C99 and C11).
const std::set<std::string> kCHeaders = {
    "assert.h",   "complex.h",  "ctype.h",  "errno.h",       "fenv.h",    "float.h",
    "inttypes.h", "iso646.h",   "limits.h", "locale.h",      "math.h",    "setjmp.h",
    "signal.h",   "stdalign.h", "stdarg.h", "stdatomic.h",   "stdbool.h", "stddef.h",
    "stdint.h",   "stdio.h",    "stdlib.h", "stdnoreturn.h", "string.h",  "tgmath.h",
    "threads.h",  "time.h",     "uchar.h",  "wchar.h",       "wctype.h"};

// The C++ standard library's headers (C++20), the <cxxx> forms included.
// clang-format off
const std::set<std::string> kCppHeaders = {
    "algorithm", "any", "array", "atomic", "barrier", "bit", "bitset", "cassert", "cctype",
    "cerrno", "cfenv", "cfloat", "charconv", "chrono", "cinttypes", "climits", "clocale", "cmath",
    "codecvt", "compare", "complex", "concepts", "condition_variable", "coroutine", "csetjmp",
    "csignal", "cstdarg", "cstddef", "cstdint", "cstdio", "cstdlib", "cstring", "ctime", "cuchar",
    "cwchar", "cwctype", "deque", "exception", "execution", "filesystem", "format",
    "forward_list", "fstream", "functional", "future", "initializer_list", "iomanip", "ios",
    "iosfwd", "iostream", "istream", "iterator", "latch", "limits", "list", "locale", "map",
    "memory", "memory_resource", "mutex", "new", "numbers", "numeric", "optional", "ostream",
    "queue", "random", "ranges", "ratio", "regex", "scoped_allocator", "semaphore", "set",
    "shared_mutex", "source_location", "span", "sstream", "stack", "stdexcept", "stop_token",
    "streambuf", "string", "string_view", "syncstream", "system_error", "thread", "tuple",
    "type_traits", "typeindex", "typeinfo", "unordered_map", "unordered_set", "utility",
    "valarray", "variant", "vector", "version"};
// clang-format on

std::string trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r");
  return std::string(s.substr(first, last - first + 1));
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool startsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

bool endsWith(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

std::vector<std::string> cellsOf(std::string_view row) {
  std::vector<std::string> cells;
  std::string text = trim(row);
  if (text.empty() || text.front() != '|') return cells;
  text.erase(0, 1);
  if (!text.empty() && text.back() == '|') text.pop_back();
  std::stringstream in(text);
  std::string cell;
  while (std::getline(in, cell, '|')) cells.push_back(trim(cell));
  return cells;
}

// The `quoted` items of a cell.
std::vector<std::string> codeItems(const std::string& cell) {
  std::vector<std::string> items;
  std::size_t at = 0;
  while ((at = cell.find('`', at)) != std::string::npos) {
    const auto end = cell.find('`', at + 1);
    if (end == std::string::npos) break;
    items.push_back(cell.substr(at + 1, end - at - 1));
    at = end + 1;
  }
  return items;
}

bool isNone(const std::string& cell) { return cell.empty() || cell == "-" || cell == "—"; }

// Whether `path` is `entry` (a file) or lies under it (a folder, ending '/').
bool covers(const std::string& entry, const std::string& path) {
  return endsWith(entry, "/") ? startsWith(path, entry) : path == entry;
}

std::string dirOf(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

}  // namespace

std::vector<Rule> parseRules(std::string_view markdown) {
  const auto begin = markdown.find(kBegin);
  const auto end = markdown.find(kEnd);
  if (begin == std::string_view::npos || end == std::string_view::npos || end < begin)
    throw RulesError("no layering table (" + std::string(kBegin) + " ... " + std::string(kEnd) +
                     ")");
  int lineNo = 1 + static_cast<int>(std::count(markdown.begin(), markdown.begin() + begin, '\n'));
  std::vector<Rule> rules;
  bool header = true;
  std::stringstream in(std::string(markdown.substr(begin, end - begin)));
  std::string text;
  for (; std::getline(in, text); ++lineNo) {
    const auto cells = cellsOf(text);
    if (cells.empty()) continue;
    const auto where = "line " + std::to_string(lineNo) + ": ";
    if (header) {  // the column titles
      header = false;
      continue;
    }
    if (cells[0].find_first_not_of("-: ") == std::string::npos) continue;  // |---|
    if (cells.size() != 3)
      throw RulesError(where + "a row has three cells (folder | ours | outside), not " +
                       std::to_string(cells.size()));
    Rule rule;
    rule.line = lineNo;
    rule.folders = codeItems(cells[0]);
    if (rule.folders.empty()) throw RulesError(where + "no `folder/` in the first cell");
    for (const auto& f : rule.folders)
      if (!endsWith(f, "/")) throw RulesError(where + "folder `" + f + "` must end with '/'");
    rule.ours = codeItems(cells[1]);
    if (rule.ours.empty() && !isNone(cells[1]))
      throw RulesError(where + "the second cell lists `folders/` or `files`, or is —");
    if (!isNone(cells[2])) {
      std::stringstream list(cells[2]);
      std::string item;
      while (std::getline(list, item, ',')) {
        const auto name = lower(trim(item));
        if (!kCategories.count(name))
          throw RulesError(where + "unknown category '" + trim(item) + "'");
        rule.outside.insert(name);
      }
    }
    rules.push_back(std::move(rule));
  }
  if (rules.empty()) throw RulesError("the layering table has no rows");
  return rules;
}

std::vector<Include> includesOf(std::string_view source) {
  std::vector<Include> out;
  std::stringstream in{std::string(source)};
  std::string text;
  for (int lineNo = 1; std::getline(in, text); ++lineNo) {
    std::size_t at = text.find_first_not_of(" \t");
    if (at == std::string::npos || text[at] != '#') continue;
    at = text.find_first_not_of(" \t", at + 1);
    if (at == std::string::npos || text.compare(at, 7, "include") != 0) continue;
    at = text.find_first_not_of(" \t", at + 7);
    if (at == std::string::npos || (text[at] != '"' && text[at] != '<')) continue;
    const char close = text[at] == '"' ? '"' : '>';
    const auto end = text.find(close, at + 1);
    if (end == std::string::npos) continue;
    out.push_back({text.substr(at + 1, end - at - 1), close == '>', lineNo});
  }
  return out;
}

std::string categoryOf(const Include& include) {
  const auto& name = include.name;
  if (kCHeaders.count(name)) return "c";
  if (kCppHeaders.count(name)) return "c++";
  if (startsWith(name, "boost/")) return "boost";
  if (startsWith(name, "yaml-cpp/")) return "yaml-cpp";
  if (name == "sqlite3.h") return "sqlite";
  if (startsWith(name, "catch2/")) return "catch2";
  if (startsWith(name, "Eigen/") || startsWith(name, "eigen3/")) return "eigen";
  if (startsWith(name, "opencv2/")) return "opencv";
  if (startsWith(name, "avr/")) return "avr-libc";
  if (startsWith(name, "dds/")) return "cyclonedds";  // benchmark peers only
  if (name == "zmq.h") return "zeromq";
  if (name == "sodium.h" || startsWith(name, "sodium/")) return "libsodium";
  if (name == "gcrypt.h") return "libgcrypt";
  if (name == "intel-ipsec-mb.h") return "ipsec-mb";
  if (startsWith(name, "sim_") || startsWith(name, "avr_") || startsWith(name, "simavr/"))
    return "simavr";
  return "system";  // POSIX and the rest of the operating system
}

std::vector<std::string> resolve(const SourceTree& tree, const std::string& from,
                                 const Include& include) {
  if (include.angled && (kCHeaders.count(include.name) || kCppHeaders.count(include.name)))
    return {};
  // "../x/y.h" names x/y.h wherever the relative path lands.
  auto name = std::filesystem::path(include.name).lexically_normal().generic_string();
  if (!include.angled) {
    const auto beside =
        std::filesystem::path(dirOf(from) + include.name).lexically_normal().generic_string();
    if (tree.count(beside)) return {beside};
    while (startsWith(name, "../")) name.erase(0, 3);
  }
  const auto suffix = (include.angled ? "include/" : "/") + name;
  std::vector<std::string> found;
  for (const auto& [path, text] : tree)
    if (endsWith(path, suffix) || (!include.angled && path == name)) found.push_back(path);
  return found;
}

const Rule* ruleFor(const std::vector<Rule>& rules, const std::string& path) {
  const Rule* best = nullptr;
  std::size_t bestLength = 0;
  for (const auto& rule : rules)
    for (const auto& folder : rule.folders)
      if (startsWith(path, folder) && folder.size() > bestLength) {
        best = &rule;
        bestLength = folder.size();
      }
  return best;
}

std::vector<Violation> check(const std::vector<Rule>& rules, const SourceTree& tree) {
  std::vector<Violation> out;
  for (const auto& [path, text] : tree) {
    if (!isSource(path)) continue;
    const Rule* rule = ruleFor(rules, path);
    if (rule == nullptr) {
      out.push_back({path, 0, "no row of the layering table covers this folder: add one"});
      continue;
    }
    auto allowed = [&](const std::string& target) {
      for (const auto& own : rule->folders)
        if (covers(own, target)) return true;
      for (const auto& entry : rule->ours)
        if (covers(entry, target)) return true;
      return false;
    };
    for (const auto& include : includesOf(text)) {
      const auto targets = resolve(tree, path, include);
      const auto shown = include.angled ? "<" + include.name + ">" : '"' + include.name + '"';
      if (targets.empty()) {
        const auto category = categoryOf(include);
        if (!rule->outside.count(category))
          out.push_back({path, include.line,
                         shown + " is " + category + ", which " + rule->folders.front() +
                             " may not include (row at line " + std::to_string(rule->line) + ")"});
        continue;
      }
      // Several files of that name: one of the row's own wins (the compiler
      // would find it first); otherwise the name must be safe whichever
      // file the include path picks, so each must be allowed.
      auto own = [&](const std::string& target) {
        return std::any_of(rule->folders.begin(), rule->folders.end(),
                           [&](const std::string& folder) { return covers(folder, target); });
      };
      if (std::any_of(targets.begin(), targets.end(), own)) continue;
      const auto bad = std::find_if_not(targets.begin(), targets.end(), allowed);
      if (bad != targets.end())
        out.push_back({path, include.line,
                       shown + " is " + *bad + ", which " + rule->folders.front() +
                           " may not include (row at line " + std::to_string(rule->line) + ")"});
    }
  }
  return out;
}

bool isSource(std::string_view path) {
  for (const auto* ext : {".h", ".hpp", ".c", ".cc", ".cpp", ".ipp", ".inl"})
    if (endsWith(path, ext)) return true;
  return false;
}

}  // namespace peis::layering
