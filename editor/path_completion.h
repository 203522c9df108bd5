// Completion of a typed path, for the editor's Open field: the entries of the typed folder whose
// names start with the typed rest, folders (shown with a trailing /) and the files the editor
// opens (scenes, .json; meshes: .ply .obj .stl .off .glb .gltf .fbx .dae .3ds, each also .xz).
#pragma once
#include <string>
#include <vector>

namespace raywarp::editor {

// Whether `name` is a file the editor opens, by its extension.
bool opens_file(const std::string& name);

// The completions of `typed`, each the whole path (folders end in /), sorted: folders first,
// then files; at most `limit`. Hidden entries (a leading .) only when the typed rest starts
// with a dot. A folder that cannot be read gives none.
std::vector<std::string> path_completions(const std::string& typed, size_t limit = 64);

// `typed` extended by what all its completions share (the Tab key): one completion whole, several
// their common prefix, none `typed` itself.
std::string complete_path(const std::string& typed);

}  // namespace raywarp::editor
