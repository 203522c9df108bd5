// `raywarp edit`: a window (GLFW, OpenGL 4.5 core, Dear ImGui) over the library's bake jobs and
// the renderer `raywarp render` uses. docs/editor.md describes what it does and its bindings.
#pragma once
#include <string>

namespace raywarp::editor {

struct EditOptions {
  std::string input;               // a scene file (.json) or a mesh file
  int width = 1280, height = 800;  // the window's size in pixels
  std::string status_file;  // rewritten (atomically) at every change of state: docs/editor.md
  std::string frame_log;    // one line per shown frame: time since start, frame time (ms)
  int up_axis = 1;          // a bare mesh's up axis: 0 x, 1 y, 2 z
  std::string shader_dir;   // "" the built-in shaders; else read from here, reloaded on change
  std::string cache_dir;    // the bake cache folder ("" the default)
  bool no_cache = false;
  int quit_after_idle = 0;  // > 0: close after this many idle seconds (scripts and tests)
};

// Runs the window until it is closed. Throws Error when the input cannot be opened or no window
// can be made (no display).
int run_editor(const EditOptions& options);

}  // namespace raywarp::editor
