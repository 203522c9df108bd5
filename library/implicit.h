// Implicit surface of S_D: a signed distance grid over a box (see DistanceGrid in textures.h).
#pragma once
#include <cstdint>
#include <functional>

#include "base/box.h"
#include "base/interrupt.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "library/textures.h"

namespace raywarp {

// How the implicit's resolution was chosen, for ImplicitSpec::resolution "auto".
struct ImplicitChoice {
  int resolution = 0;  // the voxels along the box's longest side it picked
  bool automatic = false;
  double feature = 0.0;  // the probe's kFeatureQuantile feature size, object units (0: no hits)
  int samples = 0, hits = 0, limbs = 0;  // the probe's (ThicknessProbe)
  int wanted = 0;                        // the resolution the feature asked for
  std::uint64_t budget_bytes = 0;
  bool budget_bound = false;   // the budget held it under `wanted`
  int sheets_raised_from = 0;  // the feature's resolution, when sheets raised it (else 0)
};

// The resolution of `spec` (its own when not "auto"). For "auto": probe_thickness of the part of
// `mesh` in `box`, then the least multiple of 8, at least kAutoImplicitFloorResolution, for which
// kFeatureVoxels voxels span the feature size, lowered in steps of 8 until the implicit (distance
// grid with its margin, or depth cube) fits spec.max_mib; at most 1024. Polls `interrupter`.
ImplicitChoice choose_implicit_resolution(const Mesh& mesh, const Box& box,
                                          const ImplicitSpec& spec,
                                          Interrupter* interrupter = nullptr);

// The resolution an automatic distance grid with sheets in it takes (library/sheets.h):
// kSheetAutoResolution, lowered in steps of 8 until the grid fits spec.max_mib.
int sheet_resolution(const Box& box, const ImplicitSpec& spec);

// Bytes of the distance grid of `spec` (an explicit resolution) over `box`, margin included, as
// bake_distance_grid lays it out.
std::uint64_t distance_grid_bytes(const Box& box, const ImplicitSpec& spec);

// Builds the distance grid of `mesh` over `box` (its local frame) plus spec.margin_voxels, with
// spec.resolution voxels along the box's longest side. OpenVDB's narrow-band mesh-to-volume
// (unsigned, on the triangles near the box) locates the band; values of 1.5 voxels or more,
// where OpenVDB's band expansion measures to a near rather than the nearest triangle, are
// measured again exactly. The sign (inside) comes from the generalised winding number of the
// whole mesh, so open meshes (holes, several shells) get a
// sensible inside; faces with no inside of their own become thin shells (library/sheets.h).
// Progress in stages "distance", "sign" then "sheets"; Cancelled when `interrupter` is cancelled.
// Throws Error when the grid would exceed `memory_budget_bytes`.
DistanceGrid bake_distance_grid(const Mesh& mesh, const Box& box, const ImplicitSpec& spec,
                                size_t memory_budget_bytes = size_t(2) << 30,
                                Interrupter* interrupter = nullptr);

}  // namespace raywarp
