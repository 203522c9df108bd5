#include "library/gl/shader_sources.h"

#include <set>
#include <sstream>

#include "library/error.h"

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

}  // namespace

std::string assemble_shader(const std::string& name, const std::string& defines) {
  std::set<std::string> seen;
  std::ostringstream body;
  expand(name, seen, body);
  return "#version 450 core\n" + defines + body.str();
}

}  // namespace raywarp::gl
