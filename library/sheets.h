// Sheets: faces of a mesh with no inside of their own (a cloth, a hair card, a fin, an eyelid, or a
// closed part thinner than the distance grid's voxel). The generalised winding number that signs
// the distance grid leaves both sides of such a face outside, so the signed field has no surface
// there and the face would not show. raywarp draws each sheet face as a thin shell around it
// instead: the distance grid becomes max(f, s - d) with d the distance to the sheet faces and s
// the shell's half thickness (kSheetHalfVoxels voxels), the union of the closed parts' solid and
// the shell. Closed parts keep their signed field; a mesh of both kinds gets both.
#pragma once
#include <vector>

#include "base/box.h"
#include "base/grid.h"
#include "base/interrupt.h"
#include "library/mesh.h"
#include "library/winding.h"

namespace raywarp {

// The shell's half thickness around a sheet face, in voxels of the distance grid. The trilinear
// interpolation of s - d between texel centres on either side of a sheet peaks at s - (up to
// sqrt(3) / 2 voxel) at the sheet: with s = 1 voxel the shell has no hole wherever the sheet
// crosses a voxel (measured: tests/sheets_test.cpp).
constexpr double kSheetHalfVoxels = 0.6;

// The faces of `mesh` that meet the grid's region (box frame) and have no inside of their own:
// the winding numbers at the face's centroid moved `offset` (object units) along its normal
// either way sum below 1/2 (w jumps by about 1 across any face: from 1 to 0 where the face bounds
// a solid, from about +1/2 to -1/2 across a sheet), in a connected part (faces sharing vertices)
// most of whose faces in the region are such faces: a card or a cloth, not the rim of a hole in a
// scan, which keeps its signed field. `grid`, the signed field, settles most faces first: one
// with f > 0 behind it and f < 0 in front is in the field. Degenerate faces are skipped. Polls
// `interrupter` (stage "sheets").
// With `area_share`, also the sheet faces' area over the area of all faces in the region.
std::vector<int> sheet_faces(const Mesh& mesh, const WindingNumber& winding, const Box& box,
                             const Grid3<float>& grid, double offset,
                             Interrupter* interrupter = nullptr, double* area_share = nullptr);

// grid = max(grid, half - d) where d is the distance (box frame) from a texel centre to the
// nearest face of `faces`, within half + 2 voxels of them (beyond, half - d is below any value
// the shell could raise). Parallel over slices; polls `interrupter`.
void add_sheet_shells(const Mesh& mesh, const std::vector<int>& faces, const Box& box, double half,
                      Grid3<float>& grid, Interrupter* interrupter = nullptr);

}  // namespace raywarp
