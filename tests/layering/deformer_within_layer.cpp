// Uses only what deformers/ may use: it compiles, so the other checks fail for the layering.
#include "base/error.h"
#include "deformers/registry.h"

int deformer_within_layer() { return static_cast<int>(raywarp::deformer_types().size()); }
