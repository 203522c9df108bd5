// Bakes of a deformer into the textures the ray caster reads: the inverse displacement D, the
// alpha map A of a cut, and the figures measured on them (interpolation error, Lipschitz bound,
// inverse residual). Deformers themselves (deformers/) know nothing of textures.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "base/interrupt.h"
#include "deformers/deformer.h"
#include "library/textures.h"

namespace raywarp {

// Bakes D(p') = F^-1(p') - p' at the texel centres of a grid over the bounds of F(box) (padded by
// one texel), `resolution` texels along its longest side. w = 1 where F^-1(p') lies in the box.
// With `centre_on_lower_faces`, the grid is shifted down by less than a texel (and grown by one
// along each axis) so that texel centres lie on the planes of the box's lower faces, -h: a map
// that is linear in the axis coordinate from a kink at face -a (a twist's angle, clamped to 0
// below the face) is then interpolated exactly across that face, which an animation that reads
// a thin slab next to it through a scale M (cli/animate.h) needs.
DeformationTexture bake_deformation(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                    int resolution, bool centre_on_lower_faces = false,
                                    Interrupter* interrupter = nullptr);

// The interpolation error of a baked texture: the largest |D(p') - (F^-1(p') - p')| over the
// centres of the texture's cells (where trilinear interpolation is worst, between texels) whose
// eight texels are valid and lie outside the cut, every `stride`-th cell along each axis.
double deformation_texture_error(const Deformer& deformer, const DeformationTexture& texture,
                                 int stride = 2, Interrupter* interrupter = nullptr);

// Bakes the alpha map A = deformer.alpha at the texel centres of a grid over `region` (box
// frame), `resolution` texels along its longest side. Requires deformer.has_cut().
AlphaMap bake_alpha(const Deformer& deformer, const Eigen::AlignedBox3d& region, int resolution,
                    Interrupter* interrupter = nullptr);

// A bound of ||I + J_D|| for the trilinear interpolation of `texture`, over every cell whose
// centre lies outside the cut (deformer.alpha <= 0): within a cell, dD/dx_i is a bilinear blend
// of the four cell edges' differences along x_i, so |dD/dx_i| <= m_i = max edge |dD| / spacing,
// and ||I + J_D||_2 <= 1 + ||J_D||_F <= 1 + sqrt(m_x^2 + m_y^2 + m_z^2).
double displacement_lipschitz(const Deformer& deformer, const DeformationTexture& texture,
                              Interrupter* interrupter = nullptr);

// How well a baked texture inverts a deformer (any deformer): over the valid texels (w >= 0.5),
// at texel centres p' with p = p' + D(p') (D as stored, in float), the residual |F(p) - p'|.
//   max, mean      of the residual (object units)
//   texels         valid texels measured
//   over_tolerance those with residual > tolerance (tolerance echoes the argument)
//   folded         those whose preimage has det(dF/dp) <= 0 (where the inverse is ambiguous)
// The float storage of D alone leaves a residual of about |dF/dp| 2^-24 |D|.
struct InverseResidual {
  double max = 0, mean = 0;
  long texels = 0;
  long over_tolerance = 0;
  double tolerance = 0;
  long folded = 0;
};
InverseResidual measure_inverse_residual(const Deformer& d, const DeformationTexture& texture,
                                         double tolerance, Interrupter* interrupter = nullptr);

}  // namespace raywarp
