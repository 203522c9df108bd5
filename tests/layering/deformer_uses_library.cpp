// Breaks the layering on purpose: deformers/ sees only base/ and deformers/.
#include "library/mesh.h"

int deformer_uses_library() { return 0; }
