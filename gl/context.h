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

// A headless EGL context with no surface (EGL_KHR_surfaceless_context): on a GPU through
// EGL_EXT_platform_device, else (unless hardware_only) Mesa's software device or surfaceless
// platform, which run llvmpipe. Throws Error when none gives a 4.5 core context.
std::unique_ptr<Context> create_egl_context(bool hardware_only = false);

// The context the command line asks for: "osmesa", "egl", or "auto" (EGL on a GPU when one is
// there, else OSMesa). Throws Error for another name or when the named kind is unavailable.
std::unique_ptr<Context> create_context(const std::string& kind);

}  // namespace raywarp::gl
