// The templates of the engine bundles: every file under engines/ (shaders, scripts and scenes in
// the engines' own languages), embedded at build time by scripts/embed_files.cmake, and their
// filling. A placeholder is @NAME@ (capitals, digits and underscores).
#pragma once
#include <map>
#include <string>

namespace raywarp {

// Path relative to engines/ ("unity/Raywarp.shader") -> the file's text.
const std::map<std::string, std::string>& embedded_engine_templates();

// The template at `path` with every @NAME@ replaced by values[NAME]. Throws Error when no such
// template is embedded, or when a placeholder has no value.
std::string fill_template(const std::string& path,
                          const std::map<std::string, std::string>& values);

}  // namespace raywarp
