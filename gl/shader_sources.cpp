#include "gl/shader_sources.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include "base/error.h"

namespace raywarp::gl {

namespace {

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
// names (an undefined name is 0), defined(NAME), !, + and -, ==, !=, <, <=, >, >=, &&, || and
// parentheses.
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
  long sum() {
    long v = primary();
    for (;;) {
      if (accept("+"))
        v += primary();
      else if (accept("-"))
        v -= primary();
      else
        return v;
    }
  }
  long comparison() {
    long v = sum();
    for (;;) {
      if (accept("=="))
        v = v == sum();
      else if (accept("!="))
        v = v != sum();
      else if (accept("<="))
        v = v <= sum();
      else if (accept(">="))
        v = v >= sum();
      else if (accept("<"))
        v = v < sum();
      else if (accept(">"))
        v = v > sum();
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
// taken, whether the current branch is live, and where it opened (for errors).
struct Group {
  bool parent_live;
  bool taken;
  bool live;
  std::string opened;
};

// A line the preprocessor keeps: its source string (-1: untracked), its line there, its text.
struct KeptLine {
  int file;
  int line;
  std::string text;
};

// The preprocessor subset of the assembly: conditionals resolved, comments and blank lines
// dropped, includes expanded (when it has a file table), the kept lines with their positions.
class Preprocessor {
 public:
  explicit Preprocessor(const ShaderFiles* files) : files_(files) {}

  // Processes one file's text, source string `file`, named `where` in errors.
  void run(const std::string& text, int file, const std::string& where) {
    const size_t depth = groups_.size();  // a file closes the groups it opens
    std::istringstream in(text);
    std::string raw;
    int line_number = 0;
    while (std::getline(in, raw)) {
      if (++line_number >= ShaderFiles::kLineStride && file >= 0)
        throw Error(where + ": over " + std::to_string(ShaderFiles::kLineStride - 1) +
                    " lines, more than #line can number (ShaderFiles::kLineStride)");
      const std::string line = strip_comment(raw);
      const std::string t = trim(line);
      if (t.empty()) continue;
      if (t[0] != '#') {
        if (live()) kept_.push_back({file, line_number, line});
        continue;
      }
      const std::string at = where + ":" + std::to_string(line_number);
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
            v = Condition(rest, macros_, at).evaluate() != 0;
          else
            v = (macros_.count(rest) != 0) == (directive == "ifdef");
        }
        groups_.push_back({parent, v, parent && v, at + ": #" + directive + " " + rest});
      } else if (directive == "elif") {
        if (groups_.size() == depth) throw Error(at + ": #elif without #if");
        Group& g = groups_.back();
        bool v = g.parent_live && !g.taken && Condition(rest, macros_, at).evaluate() != 0;
        g.live = v;
        g.taken = g.taken || v;
      } else if (directive == "else") {
        if (groups_.size() == depth) throw Error(at + ": #else without #if");
        Group& g = groups_.back();
        g.live = g.parent_live && !g.taken;
        g.taken = true;
      } else if (directive == "endif") {
        if (groups_.size() == depth) throw Error(at + ": #endif without #if");
        groups_.pop_back();
      } else if (!live()) {
        continue;
      } else if (directive == "include") {
        if (rest.size() < 3 || rest.front() != '"' || rest.back() != '"' ||
            rest.find('"', 1) != rest.size() - 1)
          throw Error(at + ": malformed #include (#include \"file.glsl\"): #include " + rest);
        include(rest.substr(1, rest.size() - 2), at);
      } else if (directive == "error") {
        throw Error(at + ": #error " + rest);
      } else {
        if (directive == "define") {
          std::istringstream def(rest);
          std::string name, value;
          def >> name;
          std::getline(def, value);
          macros_[name] = trim(value);
        } else if (directive == "undef") {
          macros_.erase(rest);
        }
        kept_.push_back({file, line_number, line});  // #version, #define, ...: the GL compiler's
      }
    }
    if (groups_.size() > depth)
      throw Error(groups_[depth].opened + ": no #endif in " + where +
                  (groups_.size() > depth + 1
                       ? " (" + std::to_string(groups_.size() - depth) + " groups open)"
                       : ""));
  }

  // Expands file `name` of the table where `at` (file:line) includes it; at most once.
  void include(const std::string& name, const std::string& at) {
    if (!files_) throw Error(at + ": #include \"" + name + "\" with no table of shader files");
    auto open = std::find(open_.begin(), open_.end(), name);
    if (open != open_.end()) {
      std::string cycle;
      for (auto it = open; it != open_.end(); ++it) cycle += *it + " -> ";
      throw Error(at + ": #include \"" + name + "\": an include cycle, " + cycle + name);
    }
    if (included_.count(name)) return;
    const std::string* text = files_->text(name);
    if (!text)
      throw Error(at + ": #include \"" + name +
                  "\": no such shader file (the files: " + files_->describe() + ")");
    included_.insert(name);
    open_.push_back(name);
    run(*text, files_->number(name), name);
    open_.pop_back();
  }

  // The kept lines; with `line_directives`, a `#line L S` (L = S * kLineStride + N) before every
  // line N of file S that does not follow the previous line kept in the same file.
  std::string output(bool line_directives) const {
    std::ostringstream out;
    int file = 0, line = 0;  // GLSL starts at line 1 of source string 0
    for (const KeptLine& k : kept_) {
      if (line_directives && (k.file != file || k.line != line + 1))
        out << "#line " << k.file * ShaderFiles::kLineStride + k.line << ' ' << k.file << '\n';
      out << k.text << '\n';
      file = k.file;
      line = k.line;
    }
    return out.str();
  }

 private:
  bool live() const { return groups_.empty() || groups_.back().live; }

  const ShaderFiles* files_;
  std::map<std::string, std::string> macros_;
  std::vector<Group> groups_;
  std::vector<KeptLine> kept_;
  std::set<std::string> included_;
  std::vector<std::string> open_;  // the files being expanded, outermost first
};

// The digits at `pos` of `s` as a number (advancing pos), or -1 when there are none.
long digits_at(const std::string& s, size_t& pos) {
  size_t start = pos;
  while (pos < s.size() && std::isdigit(static_cast<unsigned char>(s[pos]))) ++pos;
  if (pos == start || pos - start > 9) {
    pos = start;
    return -1;
  }
  return std::stol(s.substr(start, pos - start));
}

std::string info_log(GLuint object, bool program) {
  GLint length = 0;
  if (program)
    glGetProgramiv(object, GL_INFO_LOG_LENGTH, &length);
  else
    glGetShaderiv(object, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<size_t>(std::max(length, 1)), '\0');
  if (program)
    glGetProgramInfoLog(object, static_cast<GLsizei>(log.size()), nullptr, log.data());
  else
    glGetShaderInfoLog(object, static_cast<GLsizei>(log.size()), nullptr, log.data());
  log.resize(log.find('\0') == std::string::npos ? log.size() : log.find('\0'));
  return log;
}

}  // namespace

ShaderFiles::ShaderFiles(const std::map<std::string, std::string>& texts) : texts_(texts) {
  names_.push_back(kPreamble);
  for (const auto& [name, text] : texts_) names_.push_back(name);
}

ShaderFiles read_shader_folder(const std::filesystem::path& folder) {
  std::map<std::string, std::string> texts;
  std::error_code ec;
  std::filesystem::directory_iterator it(folder, ec);
  if (ec) throw Error(folder.string() + ": cannot read the shader folder: " + ec.message());
  for (const auto& entry : it) {
    if (entry.path().extension() != ".glsl") continue;
    std::ifstream in(entry.path(), std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(in)), {});
    if (!in && !in.eof()) throw Error(entry.path().string() + ": cannot read it");
    texts[entry.path().filename().string()] = std::move(text);
  }
  if (texts.empty())
    throw Error(folder.string() + ": holds no .glsl file (give a copy of the source's shaders/)");
  return ShaderFiles(texts);
}

const ShaderFiles& ShaderFiles::embedded() {
  static const ShaderFiles files(embedded_shaders());
  return files;
}

const std::string* ShaderFiles::text(const std::string& name) const {
  auto it = texts_.find(name);
  return it == texts_.end() ? nullptr : &it->second;
}

int ShaderFiles::number(const std::string& name) const {
  auto it = texts_.find(name);
  return it == texts_.end() ? -1 : static_cast<int>(std::distance(texts_.begin(), it)) + 1;
}

const std::string* ShaderFiles::name(int number) const {
  return number >= 0 && number < static_cast<int>(names_.size()) ? &names_[number] : nullptr;
}

std::string ShaderFiles::describe() const {
  std::string s;
  for (size_t n = 1; n < names_.size(); ++n)
    s += (n > 1 ? ", " : "") + names_[n] + " " + std::to_string(n);
  return s;
}

std::string resolve_conditionals(const std::string& text, const std::string& where) {
  Preprocessor p(nullptr);
  p.run(text, -1, where);
  return p.output(false);
}

std::string assemble_shader(const ShaderFiles& files, const std::string& name,
                            const std::string& defines) {
  if (!files.text(name))
    throw Error("shader " + name + ": not among the shader files (" + files.describe() + ")");
  Preprocessor p(&files);
  p.run("#version 450 core\n" + defines, 0, ShaderFiles::kPreamble);
  p.include(name, ShaderFiles::kPreamble);
  return p.output(true);
}

std::string assemble_shader(const std::string& name, const std::string& defines) {
  return assemble_shader(ShaderFiles::embedded(), name, defines);
}

std::string rewrite_info_log(const std::string& log, const ShaderFiles& files) {
  std::istringstream in(log);
  std::string out, line;
  bool first = true;
  while (std::getline(in, line)) {
    if (!first) out += '\n';
    first = false;
    size_t pos = 0;
    for (const char* prefix : {"ERROR: ", "WARNING: "})
      if (line.rfind(prefix, 0) == 0) pos = std::string(prefix).size();
    const size_t start = pos;
    const long source = digits_at(line, pos);
    long number = -1;
    size_t end = pos;
    if (source >= 0 && pos < line.size() && line[pos] == ':') {  // S:L, S:L(C)
      end = pos + 1;
      number = digits_at(line, end);
    } else if (source >= 0 && pos < line.size() && line[pos] == '(') {  // S(L)
      end = pos + 1;
      number = digits_at(line, end);
      if (number >= 0 && end < line.size() && line[end] == ')')
        ++end;
      else
        number = -1;
    }
    const long stride = ShaderFiles::kLineStride;
    const long file = number >= stride ? number / stride : source;
    const std::string* name = number >= 0 ? files.name(static_cast<int>(file)) : nullptr;
    if (!name) {
      out += line;
      continue;
    }
    out += line.substr(0, start) + *name + ":" + std::to_string(number % stride) + line.substr(end);
  }
  if (!log.empty() && log.back() == '\n') out += '\n';
  return out;
}

std::string stage_defines(GLenum kind) {
  return kind == GL_FRAGMENT_SHADER ? "#define RAYWARP_FRAGMENT\n" : "";
}

GLuint compile_shader(GLenum kind, const ShaderFiles& files, const std::string& name,
                      const std::string& defines) {
  const std::string text = assemble_shader(files, name, defines + stage_defines(kind));
  GLuint shader = glCreateShader(kind);
  const char* src = text.c_str();
  glShaderSource(shader, 1, &src, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    const std::string log = info_log(shader, false);
    glDeleteShader(shader);
    throw Error("shader " + name + " does not compile:\n" + rewrite_info_log(log, files));
  }
  return shader;
}

GLuint link_program(const ShaderFiles& files, const std::string& vertex,
                    const std::string& fragment, const std::string& defines) {
  GLuint vs = compile_shader(GL_VERTEX_SHADER, files, vertex, defines);
  GLuint fs = 0;
  try {
    fs = compile_shader(GL_FRAGMENT_SHADER, files, fragment, defines);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    const std::string log = info_log(program, true);
    glDeleteProgram(program);
    throw Error("shaders " + vertex + " + " + fragment + " do not link:\n" +
                rewrite_info_log(log, files));
  }
  return program;
}

}  // namespace raywarp::gl
