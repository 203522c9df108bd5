#include "gl/gl_api.h"

#include <string>

#include "base/error.h"

namespace raywarp::gl {

#define RAYWARP_GL_DEFINE(type, name) type name = nullptr;
RAYWARP_GL_FUNCTIONS(RAYWARP_GL_DEFINE)
#undef RAYWARP_GL_DEFINE

void load_gl(ProcLoader loader) {
#define RAYWARP_GL_LOAD(type, name)             \
  name = reinterpret_cast<type>(loader(#name)); \
  if (!name) throw Error(std::string("OpenGL: the context does not provide ") + #name);
  RAYWARP_GL_FUNCTIONS(RAYWARP_GL_LOAD)
#undef RAYWARP_GL_LOAD
}

}  // namespace raywarp::gl
