// Terms, preconditions and port keys of functionality descriptors
// (peis/descriptor.h): parsing and the canonical text form.
#include <cctype>

#include "peis/descriptor.h"

namespace peis {
namespace {

// Characters of a functor or a constant: a key part's characters (so facts
// and keys can carry them) less the term syntax ( ) , ? @ ! { } : and quotes.
bool isNameChar(char c) {
  const auto u = static_cast<unsigned char>(c);
  if (std::isalnum(u)) return true;
  return c == '-' || c == '_' || c == '/' || c == '+' || c == '#' || c == '~' || c == '%' ||
         c == '&' || c == '^' || c == '|' || c == '<' || c == '>' || c == ';';
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) {
    text.remove_prefix(1);
  }
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) {
    text.remove_suffix(1);
  }
  return text;
}

bool setProblem(std::string* problem, std::string why) {
  if (problem) *problem = std::move(why);
  return false;
}

bool validName(std::string_view name, const char* what, std::string* problem) {
  if (name.empty()) return setProblem(problem, std::string(what) + " is empty");
  for (char c : name) {
    if (!isNameChar(c)) {
      return setProblem(problem, std::string(what) + " '" + std::string(name) +
                                     "' has the character '" + std::string(1, c) +
                                     "', which names may not contain");
    }
  }
  return true;
}

bool validArgument(std::string_view arg, std::string* problem) {
  if (isVariable(arg)) return validName(arg.substr(1), "the variable name", problem);
  return validName(arg, "the argument", problem);
}

// Replaces each `?var` of `pattern` (as a whole key part or a part's tail)
// by nothing: the default key suffix lists the type's variables instead.
std::string withVariables(const std::string& base, const std::string& type) {
  std::string key = base;
  if (auto term = Term::parse(type)) {
    for (const auto& v : term->variables()) {
      if (v != kSelfVariable) key += "." + v;
    }
  }
  return key;
}

}  // namespace

std::optional<Term> Term::parse(std::string_view text, std::string* problem) {
  text = trim(text);
  Term term;
  const auto open = text.find('(');
  if (open == std::string_view::npos) {
    term.functor = std::string(text);
    if (!validName(term.functor, "the name", problem)) return std::nullopt;
    return term;
  }
  term.functor = std::string(trim(text.substr(0, open)));
  if (!validName(term.functor, "the name", problem)) return std::nullopt;
  if (text.back() != ')') {
    setProblem(problem, "'" + std::string(text) +
                            "' does not end with ')' (in a [flow, list] or {flow: map}, quote a "
                            "term that has a comma or a '?': \"f(?a, b)\")");
    return std::nullopt;
  }
  auto inside = text.substr(open + 1, text.size() - open - 2);
  if (trim(inside).empty()) {
    setProblem(problem, "'" + std::string(text) + "' has empty parentheses (write just the name)");
    return std::nullopt;
  }
  while (true) {
    const auto comma = inside.find(',');
    const auto arg = trim(inside.substr(0, comma));
    if (!validArgument(arg, problem)) return std::nullopt;
    term.args.emplace_back(arg);
    if (comma == std::string_view::npos) break;
    inside = inside.substr(comma + 1);
  }
  return term;
}

std::string Term::toString() const {
  if (args.empty()) return functor;
  std::string text = functor + "(";
  for (std::size_t i = 0; i < args.size(); ++i) text += (i ? "," : "") + args[i];
  return text + ")";
}

bool Term::isGround() const {
  for (const auto& a : args) {
    if (isVariable(a)) return false;
  }
  return true;
}

std::vector<std::string> Term::variables() const {
  std::vector<std::string> vars;
  for (const auto& a : args) {
    if (!isVariable(a)) continue;
    bool seen = false;
    for (const auto& v : vars) seen = seen || v == a;
    if (!seen) vars.push_back(a);
  }
  return vars;
}

std::optional<Precondition> Precondition::parse(std::string_view text, std::string* problem) {
  Precondition p;
  if (const auto ne = text.find("!="); ne != std::string_view::npos) {
    p.disequality = true;
    p.left = std::string(trim(text.substr(0, ne)));
    p.right = std::string(trim(text.substr(ne + 2)));
    if (!validArgument(p.left, problem) || !validArgument(p.right, problem)) return std::nullopt;
    if (!isVariable(p.left) && !isVariable(p.right)) {
      setProblem(problem, "a disequality needs a variable on one side");
      return std::nullopt;
    }
    return p;
  }
  auto atom = Term::parse(text, problem);
  if (!atom) return std::nullopt;
  p.atom = std::move(*atom);
  return p;
}

std::string Precondition::toString() const {
  return disequality ? left + " != " + right : atom.toString();
}

std::string Port::outputKey() const { return key.empty() ? withVariables(name, type) : key; }

std::string Port::inputKey() const { return key.empty() ? withVariables("mi-" + name, type) : key; }

std::string formatPorts(const std::vector<Port>& ports) {
  std::string text;
  for (const auto& p : ports) {
    text += (text.empty() ? "" : " ") + p.name + ":" + p.type;
    if (!p.key.empty()) text += "@" + p.key;
  }
  return text;
}

}  // namespace peis
