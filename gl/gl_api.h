// The OpenGL 4.5 core entry points raywarp uses, loaded at run time from the current context's
// loader (OSMesaGetProcAddress, eglGetProcAddress, ...). raywarp does not use libepoxy, which
// aborts under OSMesa, and does not link libGL. The pointers live in raywarp::gl, named as the
// GL functions, so code inside that namespace reads like plain OpenGL.
#pragma once
#include <GL/glcorearb.h>

// OpenGL 1.1 entry points have no PFN typedefs in Mesa's glcorearb.h.
typedef void(APIENTRYP PFNGLDRAWELEMENTSPROC)(GLenum mode, GLsizei count, GLenum type,
                                              const void* indices);
typedef void(APIENTRYP PFNGLGENTEXTURESPROC)(GLsizei n, GLuint* textures);
typedef void(APIENTRYP PFNGLBINDTEXTUREPROC)(GLenum target, GLuint texture);
typedef void(APIENTRYP PFNGLDELETETEXTURESPROC)(GLsizei n, const GLuint* textures);

namespace raywarp::gl {

#define RAYWARP_GL_FUNCTIONS(X)                                  \
  X(PFNGLGETSTRINGPROC, glGetString)                             \
  X(PFNGLGETINTEGERVPROC, glGetIntegerv)                         \
  X(PFNGLGETERRORPROC, glGetError)                               \
  X(PFNGLVIEWPORTPROC, glViewport)                               \
  X(PFNGLCLEARBUFFERFVPROC, glClearBufferfv)                     \
  X(PFNGLCLEARPROC, glClear)                                     \
  X(PFNGLCLEARCOLORPROC, glClearColor)                           \
  X(PFNGLCLEARDEPTHPROC, glClearDepth)                           \
  X(PFNGLENABLEPROC, glEnable)                                   \
  X(PFNGLDISABLEPROC, glDisable)                                 \
  X(PFNGLDEPTHFUNCPROC, glDepthFunc)                             \
  X(PFNGLDEPTHMASKPROC, glDepthMask)                             \
  X(PFNGLCULLFACEPROC, glCullFace)                               \
  X(PFNGLFINISHPROC, glFinish)                                   \
  X(PFNGLREADPIXELSPROC, glReadPixels)                           \
  X(PFNGLREADBUFFERPROC, glReadBuffer)                           \
  X(PFNGLPIXELSTOREIPROC, glPixelStorei)                         \
  X(PFNGLCREATESHADERPROC, glCreateShader)                       \
  X(PFNGLSHADERSOURCEPROC, glShaderSource)                       \
  X(PFNGLCOMPILESHADERPROC, glCompileShader)                     \
  X(PFNGLGETSHADERIVPROC, glGetShaderiv)                         \
  X(PFNGLGETSHADERINFOLOGPROC, glGetShaderInfoLog)               \
  X(PFNGLDELETESHADERPROC, glDeleteShader)                       \
  X(PFNGLCREATEPROGRAMPROC, glCreateProgram)                     \
  X(PFNGLATTACHSHADERPROC, glAttachShader)                       \
  X(PFNGLLINKPROGRAMPROC, glLinkProgram)                         \
  X(PFNGLGETPROGRAMIVPROC, glGetProgramiv)                       \
  X(PFNGLGETPROGRAMINFOLOGPROC, glGetProgramInfoLog)             \
  X(PFNGLDELETEPROGRAMPROC, glDeleteProgram)                     \
  X(PFNGLUSEPROGRAMPROC, glUseProgram)                           \
  X(PFNGLGETUNIFORMLOCATIONPROC, glGetUniformLocation)           \
  X(PFNGLUNIFORM1IPROC, glUniform1i)                             \
  X(PFNGLUNIFORM1FPROC, glUniform1f)                             \
  X(PFNGLUNIFORM2FPROC, glUniform2f)                             \
  X(PFNGLUNIFORM3FPROC, glUniform3f)                             \
  X(PFNGLUNIFORM4FPROC, glUniform4f)                             \
  X(PFNGLUNIFORMMATRIX4FVPROC, glUniformMatrix4fv)               \
  X(PFNGLUNIFORMMATRIX3FVPROC, glUniformMatrix3fv)               \
  X(PFNGLGENVERTEXARRAYSPROC, glGenVertexArrays)                 \
  X(PFNGLBINDVERTEXARRAYPROC, glBindVertexArray)                 \
  X(PFNGLDELETEVERTEXARRAYSPROC, glDeleteVertexArrays)           \
  X(PFNGLGENBUFFERSPROC, glGenBuffers)                           \
  X(PFNGLBINDBUFFERPROC, glBindBuffer)                           \
  X(PFNGLBUFFERDATAPROC, glBufferData)                           \
  X(PFNGLDELETEBUFFERSPROC, glDeleteBuffers)                     \
  X(PFNGLVERTEXATTRIBPOINTERPROC, glVertexAttribPointer)         \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, glEnableVertexAttribArray) \
  X(PFNGLDRAWELEMENTSPROC, glDrawElements)                       \
  X(PFNGLGENTEXTURESPROC, glGenTextures)                         \
  X(PFNGLBINDTEXTUREPROC, glBindTexture)                         \
  X(PFNGLACTIVETEXTUREPROC, glActiveTexture)                     \
  X(PFNGLTEXIMAGE2DPROC, glTexImage2D)                           \
  X(PFNGLTEXIMAGE3DPROC, glTexImage3D)                           \
  X(PFNGLTEXPARAMETERIPROC, glTexParameteri)                     \
  X(PFNGLDELETETEXTURESPROC, glDeleteTextures)                   \
  X(PFNGLGENFRAMEBUFFERSPROC, glGenFramebuffers)                 \
  X(PFNGLBINDFRAMEBUFFERPROC, glBindFramebuffer)                 \
  X(PFNGLFRAMEBUFFERTEXTURE2DPROC, glFramebufferTexture2D)       \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, glCheckFramebufferStatus)   \
  X(PFNGLDRAWBUFFERSPROC, glDrawBuffers)                         \
  X(PFNGLDELETEFRAMEBUFFERSPROC, glDeleteFramebuffers)           \
  X(PFNGLCLEARBUFFERIVPROC, glClearBufferiv)                     \
  X(PFNGLGENQUERIESPROC, glGenQueries)                           \
  X(PFNGLDELETEQUERIESPROC, glDeleteQueries)                     \
  X(PFNGLBEGINQUERYPROC, glBeginQuery)                           \
  X(PFNGLENDQUERYPROC, glEndQuery)                               \
  X(PFNGLGETQUERYOBJECTUIVPROC, glGetQueryObjectuiv)             \
  X(PFNGLTEXTUREBARRIERPROC, glTextureBarrier)

#define RAYWARP_GL_DECLARE(type, name) extern type name;
RAYWARP_GL_FUNCTIONS(RAYWARP_GL_DECLARE)
#undef RAYWARP_GL_DECLARE

using ProcLoader = void* (*)(const char* name);
// Loads every entry point above; throws Error naming the first one that is missing.
void load_gl(ProcLoader loader);

}  // namespace raywarp::gl
