// OSMesa lives in this file alone: <GL/osmesa.h> drags in the legacy GL header.
#include <GL/osmesa.h>

#include <vector>

#include "base/error.h"
#include "gl/context.h"
#include "gl/gl_api.h"

namespace raywarp::gl {

namespace {

class OSMesaContextImpl : public Context {
 public:
  OSMesaContextImpl() {
    const int attribs[] = {OSMESA_FORMAT,
                           OSMESA_RGBA,
                           OSMESA_DEPTH_BITS,
                           24,
                           OSMESA_PROFILE,
                           OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION,
                           4,
                           OSMESA_CONTEXT_MINOR_VERSION,
                           5,
                           0};
    ctx_ = OSMesaCreateContextAttribs(attribs, nullptr);
    if (!ctx_) throw Error("OSMesa: cannot create an OpenGL 4.5 core context");
    // The default framebuffer is unused (rendering goes to a framebuffer object) but OSMesa
    // needs one to make the context current.
    buffer_.assign(4 * kSide * kSide, 0);
    if (!OSMesaMakeCurrent(ctx_, buffer_.data(), GL_UNSIGNED_BYTE, kSide, kSide)) {
      OSMesaDestroyContext(ctx_);
      throw Error("OSMesa: cannot make the context current");
    }
    load_gl([](const char* name) { return reinterpret_cast<void*>(OSMesaGetProcAddress(name)); });
    description_ = std::string("OSMesa: ") +
                   reinterpret_cast<const char*>(glGetString(GL_VERSION)) + ", " +
                   reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  }
  ~OSMesaContextImpl() override { OSMesaDestroyContext(ctx_); }
  std::string description() const override { return description_; }

 private:
  static constexpr int kSide = 16;
  OSMesaContext ctx_ = nullptr;
  std::vector<unsigned char> buffer_;
  std::string description_;
};

}  // namespace

std::unique_ptr<Context> create_osmesa_context() { return std::make_unique<OSMesaContextImpl>(); }

}  // namespace raywarp::gl
