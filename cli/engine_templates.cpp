#include "cli/engine_templates.h"

#include <regex>

#include "base/error.h"

namespace raywarp {

std::string fill_template(const std::string& path,
                          const std::map<std::string, std::string>& values) {
  const auto found = embedded_engine_templates().find(path);
  if (found == embedded_engine_templates().end())
    throw Error("no engine template engines/" + path + " is embedded in this raywarp");
  const std::string& text = found->second;
  static const std::regex placeholder("@([A-Z][A-Z0-9_]*)@");
  std::string out;
  size_t last = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), placeholder);
       it != std::sregex_iterator(); ++it) {
    const std::smatch& m = *it;
    const auto value = values.find(m[1]);
    if (value == values.end())
      throw Error("engines/" + path + ": no value for its placeholder @" + m[1].str() + "@");
    out += text.substr(last, m.position(0) - last) + value->second;
    last = m.position(0) + m.length(0);
  }
  return out + text.substr(last);
}

}  // namespace raywarp
