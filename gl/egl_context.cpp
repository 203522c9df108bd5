// EGL lives in this file alone. A headless context with no surface at all
// (EGL_KHR_surfaceless_context): rendering goes to the renderer's framebuffer object.
// The display comes from EGL_EXT_platform_device (a GPU, or Mesa's software device), else
// Mesa's surfaceless platform (EGL_MESA_platform_surfaceless), else the default display.
#define EGL_NO_X11
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <string>
#include <vector>

#include "base/error.h"
#include "gl/context.h"
#include "gl/gl_api.h"

namespace raywarp::gl {

namespace {

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const std::string all = std::string(" ") + list + " ";
  return all.find(std::string(" ") + name + " ") != std::string::npos;
}

// Candidate displays, hardware devices first.
std::vector<EGLDisplay> candidate_displays(bool hardware_only) {
  std::vector<EGLDisplay> out;
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  auto query_devices =
      reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  auto query_device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
      eglGetProcAddress("eglQueryDeviceStringEXT"));
  if (get_platform_display && query_devices && has_extension(client, "EGL_EXT_platform_device")) {
    EGLDeviceEXT devices[16];
    EGLint count = 0;
    if (query_devices(16, devices, &count)) {
      std::vector<EGLDisplay> software;
      for (EGLint i = 0; i < count; ++i) {
        const char* ext =
            query_device_string ? query_device_string(devices[i], EGL_EXTENSIONS) : nullptr;
        const bool is_software = has_extension(ext, "EGL_MESA_device_software");
        EGLDisplay d = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (d == EGL_NO_DISPLAY) continue;
        (is_software ? software : out).push_back(d);
      }
      if (!hardware_only) out.insert(out.end(), software.begin(), software.end());
    }
  }
  if (hardware_only) return out;
  if (get_platform_display && has_extension(client, "EGL_MESA_platform_surfaceless")) {
    EGLDisplay d =
        get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (d != EGL_NO_DISPLAY) out.push_back(d);
  }
  EGLDisplay d = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (d != EGL_NO_DISPLAY) out.push_back(d);
  return out;
}

class EglContextImpl : public Context {
 public:
  explicit EglContextImpl(bool hardware_only) {
    std::string why = "no EGL display";
    for (EGLDisplay display : candidate_displays(hardware_only)) {
      if (try_display(display, why)) return;
    }
    throw Error(std::string("EGL: cannot create a headless OpenGL 4.5 core context") +
                (hardware_only ? " on a GPU" : "") + " (" + why + ")");
  }
  ~EglContextImpl() override {
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
    eglTerminate(display_);
  }
  std::string description() const override { return description_; }

 private:
  bool try_display(EGLDisplay display, std::string& why) {
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) {
      why = "eglInitialize failed";
      return false;
    }
    const char* ext = eglQueryString(display, EGL_EXTENSIONS);
    if (!has_extension(ext, "EGL_KHR_surfaceless_context") || !eglBindAPI(EGL_OPENGL_API)) {
      why = "no surfaceless desktop OpenGL";
      eglTerminate(display);
      return false;
    }
    const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint configs = 0;
    const bool no_config = has_extension(ext, "EGL_KHR_no_config_context");
    if (!eglChooseConfig(display, config_attribs, &config, 1, &configs) || configs < 1) {
      if (!no_config) {
        why = "no OpenGL config";
        eglTerminate(display);
        return false;
      }
      config = nullptr;  // EGL_NO_CONFIG_KHR
    }
    const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                      4,
                                      EGL_CONTEXT_MINOR_VERSION,
                                      5,
                                      EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                      EGL_NONE};
    EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
    if (context == EGL_NO_CONTEXT) {
      why = "eglCreateContext for OpenGL 4.5 core failed";
      eglTerminate(display);
      return false;
    }
    if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
      why = "eglMakeCurrent failed";
      eglDestroyContext(display, context);
      eglTerminate(display);
      return false;
    }
    display_ = display;
    context_ = context;
    load_gl([](const char* name) { return reinterpret_cast<void*>(eglGetProcAddress(name)); });
    description_ = std::string("EGL ") + std::to_string(major) + "." + std::to_string(minor) +
                   ": " + reinterpret_cast<const char*>(glGetString(GL_VERSION)) + ", " +
                   reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    return true;
  }

  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  std::string description_;
};

}  // namespace

std::unique_ptr<Context> create_egl_context(bool hardware_only) {
  return std::make_unique<EglContextImpl>(hardware_only);
}

std::unique_ptr<Context> create_context(const std::string& kind) {
  if (kind == "osmesa") return create_osmesa_context();
  if (kind == "egl") return create_egl_context(false);
  if (kind == "auto") {
    try {
      return create_egl_context(true);
    } catch (const Error&) {
      return create_osmesa_context();
    }
  }
  throw Error("--context " + kind + ": must be one of auto, egl, osmesa");
}

}  // namespace raywarp::gl
