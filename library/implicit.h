// Implicit surface of S_D: a signed distance grid over a box (see DistanceGrid in textures.h).
#pragma once
#include <functional>

#include "base/box.h"
#include "base/interrupt.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "library/textures.h"

namespace raywarp {

// Builds the distance grid of `mesh` over `box` (its local frame) plus spec.margin_voxels, with
// spec.resolution voxels along the box's longest side. OpenVDB's narrow-band mesh-to-volume
// (unsigned, on the triangles near the box) locates the band; values of 1.5 voxels or more,
// where OpenVDB's band expansion measures to a near rather than the nearest triangle, are
// measured again exactly. The sign (inside) comes from the generalised winding number of the
// whole mesh, so open meshes (holes, several shells) get a
// sensible inside. Progress in stages "distance" then "sign"; Cancelled when `interrupter` is
// cancelled. Throws Error when the grid would exceed `memory_budget_bytes`.
DistanceGrid bake_distance_grid(const Mesh& mesh, const Box& box, const ImplicitSpec& spec,
                                size_t memory_budget_bytes = size_t(2) << 30,
                                Interrupter* interrupter = nullptr);

}  // namespace raywarp
