#include "gl/shader_sources.h"

#include <cctype>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include "base/error.h"

namespace raywarp::gl {

namespace {

void expand(const std::string& name, std::set<std::string>& seen, std::ostringstream& out) {
  const auto& sources = embedded_shaders();
  auto it = sources.find(name);
  if (it == sources.end()) throw Error("shader " + name + ": not among the embedded shaders");
  if (!seen.insert(name).second) return;
  std::istringstream in(it->second);
  std::string line;
  while (std::getline(in, line)) {
    const std::string directive = "#include \"";
    if (line.rfind(directive, 0) == 0) {
      auto end = line.find('"', directive.size());
      expand(line.substr(directive.size(), end - directive.size()), seen, out);
    } else {
      out << line << '\n';
    }
  }
}

std::string trim(const std::string& s) {
  size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

// The line without its // comment and trailing blanks (GLSL has no string literals).
std::string strip_comment(const std::string& line) {
  std::string s = line.substr(0, line.find("//"));
  return s.substr(0, s.find_last_not_of(" \t\r") + 1);
}

// Evaluates a #if condition of the preprocessor subset the shaders use: integer literals, macro
// names (an undefined name is 0), defined(NAME), !, ==, !=, <, <=, >, >=, &&, || and parentheses.
class Condition {
 public:
  Condition(const std::string& text, const std::map<std::string, std::string>& macros,
            const std::string& where)
      : text_(text), macros_(macros), where_(where) {}

  long evaluate() {
    long v = disjunction();
    skip_space();
    if (pos_ != text_.size()) fail("unexpected '" + text_.substr(pos_) + "'");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(where_ + ": #if " + text_ + ": " + what);
  }
  void skip_space() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  }
  bool accept(const std::string& token) {
    skip_space();
    if (text_.compare(pos_, token.size(), token) != 0) return false;
    pos_ += token.size();
    return true;
  }
  std::string identifier() {
    skip_space();
    size_t start = pos_;
    while (pos_ < text_.size() &&
           (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '_'))
      ++pos_;
    if (start == pos_) fail("expected a name at '" + text_.substr(start) + "'");
    return text_.substr(start, pos_ - start);
  }
  long macro_value(const std::string& name) {
    auto it = macros_.find(name);
    if (it == macros_.end()) return 0;
    const std::string value = trim(it->second);
    if (value.empty()) fail(name + " is defined with no value");
    try {
      size_t used = 0;
      long v = std::stol(value, &used);
      if (used == value.size()) return v;
    } catch (const std::exception&) {
    }
    fail(name + " = '" + value + "' is not an integer");
  }
  long primary() {
    skip_space();
    if (accept("(")) {
      long v = disjunction();
      if (!accept(")")) fail("missing ')'");
      return v;
    }
    if (accept("!")) return !primary();
    if (pos_ < text_.size() && std::isdigit(static_cast<unsigned char>(text_[pos_]))) {
      size_t used = 0;
      long v = std::stol(text_.substr(pos_), &used);
      pos_ += used;
      return v;
    }
    std::string name = identifier();
    if (name == "defined") {
      bool paren = accept("(");
      std::string macro = identifier();
      if (paren && !accept(")")) fail("missing ')' after defined(" + macro);
      return macros_.count(macro) ? 1 : 0;
    }
    return macro_value(name);
  }
  long comparison() {
    long v = primary();
    for (;;) {
      if (accept("=="))
        v = v == primary();
      else if (accept("!="))
        v = v != primary();
      else if (accept("<="))
        v = v <= primary();
      else if (accept(">="))
        v = v >= primary();
      else if (accept("<"))
        v = v < primary();
      else if (accept(">"))
        v = v > primary();
      else
        return v;
    }
  }
  long conjunction() {
    long v = comparison();
    while (accept("&&")) {
      long w = comparison();
      v = v && w;
    }
    return v;
  }
  long disjunction() {
    long v = conjunction();
    while (accept("||")) {
      long w = conjunction();
      v = v || w;
    }
    return v;
  }

  std::string text_;
  const std::map<std::string, std::string>& macros_;
  std::string where_;
  size_t pos_ = 0;
};

// One open #if group: whether the enclosing text is live, whether a branch of this group was
// taken, and whether the current branch is live.
struct Group {
  bool parent_live;
  bool taken;
  bool live;
};

}  // namespace

std::string resolve_conditionals(const std::string& text, const std::string& where) {
  std::map<std::string, std::string> macros;
  std::vector<Group> groups;
  std::istringstream in(text);
  std::ostringstream out;
  std::string raw;
  int line_number = 0;
  auto live = [&] { return groups.empty() || groups.back().live; };
  while (std::getline(in, raw)) {
    ++line_number;
    const std::string line = strip_comment(raw);
    const std::string at = where + ":" + std::to_string(line_number);
    const std::string t = trim(line);
    if (t.empty()) continue;
    if (t[0] != '#') {
      if (live()) out << line << '\n';
      continue;
    }
    std::istringstream words(t.substr(1));
    std::string directive;
    words >> directive;
    std::string rest;
    std::getline(words, rest);
    rest = trim(rest);
    if (directive == "if" || directive == "ifdef" || directive == "ifndef") {
      bool parent = live();
      bool v = false;
      if (parent) {
        if (directive == "if")
          v = Condition(rest, macros, at).evaluate() != 0;
        else
          v = (macros.count(rest) != 0) == (directive == "ifdef");
      }
      groups.push_back({parent, v, parent && v});
    } else if (directive == "elif") {
      if (groups.empty()) throw Error(at + ": #elif without #if");
      Group& g = groups.back();
      bool v = g.parent_live && !g.taken && Condition(rest, macros, at).evaluate() != 0;
      g.live = v;
      g.taken = g.taken || v;
    } else if (directive == "else") {
      if (groups.empty()) throw Error(at + ": #else without #if");
      Group& g = groups.back();
      g.live = g.parent_live && !g.taken;
      g.taken = true;
    } else if (directive == "endif") {
      if (groups.empty()) throw Error(at + ": #endif without #if");
      groups.pop_back();
    } else {
      if (!live()) continue;
      if (directive == "define") {
        std::istringstream def(rest);
        std::string name, value;
        def >> name;
        std::getline(def, value);
        macros[name] = trim(value);
      } else if (directive == "undef") {
        macros.erase(rest);
      }
      out << line << '\n';  // #version, #define, #extension, ... are the GL compiler's too
    }
  }
  if (!groups.empty())
    throw Error(where + ": " + std::to_string(groups.size()) + " #if without #endif");
  return out.str();
}

std::string assemble_shader(const std::string& name, const std::string& defines) {
  std::set<std::string> seen;
  std::ostringstream body;
  expand(name, seen, body);
  return resolve_conditionals("#version 450 core\n" + defines + body.str(), "shader " + name);
}

}  // namespace raywarp::gl
