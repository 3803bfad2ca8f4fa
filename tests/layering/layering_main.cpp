// peis-layering-check: checks every C and C++ file of the repository against
// the layering table of docs/architecture.md (see layering.h). Build trees
// (folders holding a CMakeCache.txt) and hidden folders are skipped.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "layering.h"

namespace fs = std::filesystem;

namespace {

const char* kUsage =
    "Usage: peis-layering-check [--rules FILE] ROOT\n"
    "\n"
    "Checks the #include lines of every C and C++ file under ROOT against the\n"
    "layering table (default ROOT/docs/architecture.md). Prints each include a\n"
    "folder may not use and exits 1 if there is one, 0 if there is none.\n";

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

peis::layering::SourceTree loadTree(const fs::path& root) {
  peis::layering::SourceTree tree;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator();
       ++it) {
    const auto& path = it->path();
    if (it->is_directory()) {
      if (path.filename().string().rfind('.', 0) == 0 || fs::exists(path / "CMakeCache.txt"))
        it.disable_recursion_pending();
      continue;
    }
    const auto relative = fs::relative(path, root).generic_string();
    if (it->is_regular_file() && peis::layering::isSource(relative))
      tree[relative] = readFile(path);
  }
  return tree;
}

}  // namespace

int main(int argc, char** argv) {
  fs::path root, rules;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return 0;
    } else if (arg == "--rules" && i + 1 < argc) {
      rules = argv[++i];
    } else if (root.empty() && arg.rfind("-", 0) != 0) {
      root = arg;
    } else {
      std::cerr << "peis-layering-check: unexpected argument '" << arg << "'\n" << kUsage;
      return 2;
    }
  }
  if (root.empty()) {
    std::cerr << kUsage;
    return 2;
  }
  if (rules.empty()) rules = root / "docs" / "architecture.md";
  try {
    const auto table = peis::layering::parseRules(readFile(rules));
    const auto tree = loadTree(root);
    const auto violations = peis::layering::check(table, tree);
    for (const auto& v : violations)
      std::cout << v.file << ":" << v.line << ": " << v.message << "\n";
    std::size_t includes = 0;
    for (const auto& [path, text] : tree) includes += peis::layering::includesOf(text).size();
    std::cout << "peis-layering-check: " << tree.size() << " files, " << includes << " includes, "
              << table.size() << " rows of " << rules.string() << ": " << violations.size()
              << " violation(s)\n";
    return violations.empty() ? 0 : 1;
  } catch (const peis::layering::RulesError& e) {
    std::cerr << "peis-layering-check: " << rules.string() << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "peis-layering-check: " << e.what() << "\n";
    return 2;
  }
}
