#include "editor/path_completion.h"

#include <algorithm>
#include <filesystem>
#include <system_error>

namespace raywarp::editor {

namespace fs = std::filesystem;

bool opens_file(const std::string& name) {
  std::string n = name;
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return std::tolower(c); });
  if (n.size() > 3 && n.compare(n.size() - 3, 3, ".xz") == 0) n.resize(n.size() - 3);
  for (const char* ext :
       {".json", ".ply", ".obj", ".stl", ".off", ".glb", ".gltf", ".fbx", ".dae", ".3ds"}) {
    const std::string e = ext;
    if (n.size() > e.size() && n.compare(n.size() - e.size(), e.size(), e) == 0) return true;
  }
  return false;
}

std::vector<std::string> path_completions(const std::string& typed, size_t limit) {
  const size_t slash = typed.rfind('/');
  const std::string folder = slash == std::string::npos ? "" : typed.substr(0, slash + 1);
  const std::string rest = slash == std::string::npos ? typed : typed.substr(slash + 1);
  std::vector<std::string> folders, files;
  std::error_code ec;
  fs::directory_iterator it(folder.empty() ? fs::path(".") : fs::path(folder), ec);
  if (ec) return {};
  for (const fs::directory_entry& e : it) {
    const std::string name = e.path().filename().string();
    if (name.compare(0, rest.size(), rest) != 0) continue;
    if (!name.empty() && name[0] == '.' && (rest.empty() || rest[0] != '.')) continue;
    std::error_code dir_ec;
    if (e.is_directory(dir_ec))
      folders.push_back(folder + name + "/");
    else if (opens_file(name))
      files.push_back(folder + name);
  }
  std::sort(folders.begin(), folders.end());
  std::sort(files.begin(), files.end());
  folders.insert(folders.end(), files.begin(), files.end());
  if (folders.size() > limit) folders.resize(limit);
  return folders;
}

std::string complete_path(const std::string& typed) {
  const std::vector<std::string> all = path_completions(typed, size_t(-1));
  if (all.empty()) return typed;
  std::string common = all.front();
  for (const std::string& c : all) {
    size_t n = 0;
    while (n < common.size() && n < c.size() && common[n] == c[n]) ++n;
    common.resize(n);
  }
  return common.size() > typed.size() ? common : typed;
}

}  // namespace raywarp::editor
