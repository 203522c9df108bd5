// Bakes of a deformer into the textures the ray caster reads: the inverse displacement D, the
// alpha map A of a cut, and the figures measured on them (interpolation error, Lipschitz bound,
// inverse residual). Deformers themselves (deformers/) know nothing of textures.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

#include "base/interrupt.h"
#include "deformers/deformer.h"
#include "library/textures.h"

namespace raywarp {

// Bakes D(p') = F^-1(p') - p' at the texel centres of a grid over the bounds of F(box) (padded by
// one texel), `resolution` texels along its longest side (cubic texels). w = 1 where F^-1(p')
// lies in the box.
// With `centre_on_lower_faces`, the grid is shifted down by less than a texel (and grown by one
// along each axis) so that texel centres lie on the planes of the box's lower faces, -h: a map
// that is linear in the axis coordinate from a kink at face -a (a twist's angle, clamped to 0
// below the face) is then interpolated exactly across that face, which an animation that reads
// a thin slab next to it through a scale M (cli/animate.h) needs.
DeformationTexture bake_deformation(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    int resolution, bool centre_on_lower_faces = false,
                                    Interrupter* interrupter = nullptr);
// The same with `counts` texels along the axes (each >= 3; one of them pads each side), so that
// texels are boxes with a side per axis.
DeformationTexture bake_deformation(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    const Eigen::Vector3i& counts, bool centre_on_lower_faces,
                                    Interrupter* interrupter = nullptr);
// The grids those two bake on (texels laid out, all zero; before the lower-face shift).
Grid3<Eigen::Vector4f> deformation_layout(const Deformer& deformer,
                                          const Eigen::Vector3d& half_extents, int resolution);
Grid3<Eigen::Vector4f> deformation_layout(const Deformer& deformer,
                                          const Eigen::Vector3d& half_extents,
                                          const Eigen::Vector3i& counts);

// How an automatic layout ("resolution": "auto") was chosen.
struct ResolutionChoice {
  bool automatic = false;
  double target = 0.0;             // the error aimed at, object units
  std::uint64_t budget_bytes = 0;  // the most the texture may take
  int bakes = 0;                   // layouts baked to get there
  bool budget_bound = false;       // the budget, not the target, set the counts
};

// Per axis a, an estimate of the error of linear interpolation along a halfway between texels:
// the largest |D(i+1) - 2 D(i) + D(i-1)| / 8 over the valid texels (with valid neighbours along a,
// not next to a cut), which is h_a^2 |d^2 D / dx_a^2| / 8 to leading order. Trilinear
// interpolation's error is about the sum of the three (mixed terms are interpolated exactly).
Eigen::Vector3d axis_interpolation_errors(const Deformer& deformer,
                                          const DeformationTexture& texture,
                                          Interrupter* interrupter = nullptr);
// Texel counts, none below `floor`, whose errors (scaled from `errors`, measured at `counts`, as
// 1 / n^2) sum to at most `target`, with the fewest texels: equal shares among the axes above
// their floor. At most 1024 per axis.
Eigen::Vector3i counts_for_error(const Eigen::Vector3i& counts, const Eigen::Vector3d& errors,
                                 double target, const Eigen::Vector3i& floor);

// An automatic layout: starts from the cubic layout of `floor_resolution` texels along the
// longest side, measures deformation_texture_error, and while it exceeds `target` refines the
// axes whose interpolation error demands it (axis_interpolation_errors, counts_for_error), at
// most four bakes, never past `budget_bytes` (all axes are scaled down alike to fit). A round
// that does not lower the error (a kink's or a jump's, which the per-axis estimates misread) is
// followed by one that refines every axis alike, and the best bake is the one returned.
struct AutoDeformation {
  DeformationTexture texture;  // bake_seconds: all bakes and measurements together
  double error = 0.0;          // deformation_texture_error of `texture`
  ResolutionChoice choice;
};
AutoDeformation bake_deformation_auto(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                      double target, std::uint64_t budget_bytes,
                                      int floor_resolution, bool centre_on_lower_faces,
                                      Interrupter* interrupter = nullptr);

// The interpolation error of a baked texture: the largest |D(p') - (F^-1(p') - p')| over the
// centres of the texture's cells (where trilinear interpolation is worst, between texels) whose
// eight texels are valid and lie outside the cut, every `stride`-th cell along each axis.
double deformation_texture_error(const Deformer& deformer, const DeformationTexture& texture,
                                 int stride = 2, Interrupter* interrupter = nullptr);

// Bakes the alpha map A = deformer.alpha at the texel centres of a grid over `region` (box
// frame), `resolution` texels along its longest side (cubic texels), or `counts` texels along
// the axes of `region` exactly. Requires deformer.has_cut().
AlphaMap bake_alpha(const Deformer& deformer, const Eigen::AlignedBox3d& region, int resolution,
                    Interrupter* interrupter = nullptr);
AlphaMap bake_alpha(const Deformer& deformer, const Eigen::AlignedBox3d& region,
                    const Eigen::Vector3i& counts, Interrupter* interrupter = nullptr);
// The interpolation error of an alpha map where it places the cut face: the largest
// |A(x) - deformer.alpha(x)| over the cell centres x with |deformer.alpha(x)| < band, every
// `stride`-th cell along each axis.
double alpha_map_error(const Deformer& deformer, const AlphaMap& map, double band, int stride = 1,
                       Interrupter* interrupter = nullptr);
// axis_interpolation_errors for an alpha map, over its texels with |A| < band.
Eigen::Vector3d alpha_axis_errors(const AlphaMap& map, double band,
                                  Interrupter* interrupter = nullptr);
// An automatic alpha map, as bake_deformation_auto: from the cubic layout of `floor_resolution`
// texels up, refined until alpha_map_error(band) <= target, within `budget_bytes`. A's kinks
// (the cut region's edges) interpolate with an error that falls as 1 / n, not 1 / n^2: the four
// bakes may end above the target there, which `error` tells.
struct AutoAlpha {
  AlphaMap map;
  double error = 0.0;
  ResolutionChoice choice;
};
AutoAlpha bake_alpha_auto(const Deformer& deformer, const Eigen::AlignedBox3d& region,
                          double target, double band, std::uint64_t budget_bytes,
                          int floor_resolution, Interrupter* interrupter = nullptr);

// A bound of ||I + J_D|| for the trilinear interpolation of `texture`, over every cell whose
// centre lies outside the cut (deformer.alpha <= 0): within a cell, dD/dx_i is a bilinear blend
// of the four cell edges' differences along x_i, so |dD/dx_i| <= m_i = max edge |dD| / spacing,
// and ||I + J_D||_2 <= 1 + ||J_D||_F <= 1 + sqrt(m_x^2 + m_y^2 + m_z^2).
double displacement_lipschitz(const Deformer& deformer, const DeformationTexture& texture,
                              Interrupter* interrupter = nullptr);

// How well a baked texture inverts a deformer (any deformer): over the valid texels (w >= 0.5)
// outside a cut, at texel centres p' with p = p' + D(p') (D as stored, in float), the residual
// |F(p) - p'|.
//   max, mean      of the residual (object units)
//   texels         valid texels measured
//   in_cut         valid texels left out because they lie in the cut (A(p') > 0): the region a
//                  cut empties (a peel's vacated gap) has no preimage by design, and the
//                  renderer draws nothing there whatever D says
//   over_tolerance those with residual > tolerance (tolerance echoes the argument)
//   folded         those whose preimage has det(dF/dp) <= 0 (where the inverse is ambiguous)
// The float storage of D alone leaves a residual of about |dF/dp| 2^-24 |D|.
struct InverseResidual {
  double max = 0, mean = 0;
  long texels = 0;
  long in_cut = 0;
  long over_tolerance = 0;
  double tolerance = 0;
  long folded = 0;
};
InverseResidual measure_inverse_residual(const Deformer& d, const DeformationTexture& texture,
                                         double tolerance, Interrupter* interrupter = nullptr);

}  // namespace raywarp
