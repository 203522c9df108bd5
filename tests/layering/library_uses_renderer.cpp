// Breaks the layering on purpose: the core library does not depend on the renderer.
#include "gl/renderer.h"

int library_uses_renderer() { return 0; }
