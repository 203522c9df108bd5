// Breaks the layering on purpose (tests/layering/expect.cmake): deformers know no GL.
#include <GL/gl.h>

#include "deformers/deformer.h"

int deformer_uses_gl() { return GL_TRIANGLES; }
