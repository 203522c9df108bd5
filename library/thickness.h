// How thin the part of a mesh inside a box is: a shape-diameter probe (Shapira, Shamir and
// Cohen-Or 2008, with one ray per sample instead of a cone). The distance grid's automatic
// resolution (implicit.resolution "auto", choose_implicit_resolution in library/implicit.h)
// follows it, so that a limb a few voxels thick at the default grid gets a finer one.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "base/box.h"
#include "base/interrupt.h"
#include "library/mesh.h"

namespace raywarp {

struct ThicknessProbe {
  int samples = 0;  // points placed on the triangles inside the box
  int hits = 0;     // rays that met the wall across the solid (open sheets and edges meet none)
  int limbs = 0;    // of the hits, those on a limb (narrow across the chord as well)
  // Per hit, the feature size (object units), sorted ascending: the thickness (the chord to the
  // wall across) on a limb; twice that on a sheet, which stays whole in a grid at half the
  // voxels across that a limb needs.
  std::vector<double> features;
  // The q-quantile of `features`, q in [0, 1] (nearest rank); 0 when nothing was hit.
  double quantile(double q) const;
};

// Places `samples` points on the triangles inside `box` (its local frame), area-weighted by a
// fixed low-discrepancy sequence (the same mesh and box give the same answer), and from each
// casts a ray inwards (against the triangle's normal) to the nearest triangle: when that one
// faces along the ray it is the wall across the solid, and the chord is the thickness there
// (a ray that meets nothing within the box's diagonal, or first a triangle that faces it, counts
// no thickness). From the chord's middle, rays along four diameters perpendicular to it measure
// the solid's narrowest width across: under 3 thicknesses it is a limb, otherwise a sheet. Polls
// `interrupter` in stage "thickness".
ThicknessProbe probe_thickness(const Mesh& mesh, const Box& box, int samples = 2048,
                               Interrupter* interrupter = nullptr);

}  // namespace raywarp
