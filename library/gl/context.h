// OpenGL contexts. Every context is OpenGL 4.5 core, headless, and renders into the renderer's
// own framebuffer object; the renderer does not know which kind it runs in.
#pragma once
#include <memory>
#include <string>

namespace raywarp::gl {

class Context {
 public:
  virtual ~Context() = default;
  // e.g. "OSMesa: 4.5 (Core Profile) Mesa 22.3.6, llvmpipe (LLVM 15, 256 bits)"
  virtual std::string description() const = 0;
};

// An OSMesa (software) context, made current on the calling thread with GL entry points
// loaded. Throws Error when OSMesa cannot give a 4.5 core context.
std::unique_ptr<Context> create_osmesa_context();

}  // namespace raywarp::gl
