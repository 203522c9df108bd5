// Composition of deformers in one box: F = F_n o ... o F_2 o F_1 (F_1 applied first), as a scene
// box's "deformer": [first, second, ...] list asks.
//
// Each F_i is defined on all of space, not only its box: twist and bend continue rigidly beyond
// their limits along their axis (as Blender's Simple Deform does), control points as their
// header states. So F_2 sees the points F_1 moved out of the box (a twist's corners) and maps
// them by its own continuation.
//
//   forward:   F(p)     = F_n(... F_1(p))
//   jacobian:  dF/dp    = J_n(p_{n-1}) ... J_2(p_1) J_1(p),  p_i = F_i(... F_1(p))  (chain rule)
//   inverse:   F^-1(p') = F_1^-1(... F_n^-1(p'))   (the inverse of F_2 o F_1 is F_1^-1 o F_2^-1)
// identity_faces(): a face is the identity under F when it is under every F_i (F_1 leaves its
// points in place, so F_2 sees the same face), a sufficient condition; where it does not hold the
// pipeline reports a torn face.
// Where some F_i folds, F folds (det dF/dp is the product of the dets); measure_folds sees it.
//
// Cuts (peel, incision, box_cut) do not compose: their alpha map is a distance field in the
// frame of their own deformed box, which a later deformer would distort. make_composed rejects
// them, and a list of one deformer is that deformer itself.
#pragma once
#include <memory>
#include <vector>

#include "deformers/deformer.h"

namespace raywarp {

// Throws raywarp::Error when `parts` is empty or holds a null pointer or a cut deformer (naming
// its index, "[1]", and what it is).
std::unique_ptr<Deformer> make_composed(std::vector<std::shared_ptr<const Deformer>> parts);

}  // namespace raywarp
