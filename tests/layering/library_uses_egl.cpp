// Breaks the layering on purpose: the core library makes no GL context.
#include <EGL/egl.h>

int library_uses_egl() { return 0; }
