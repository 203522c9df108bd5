// Cylindrical texture coordinates: eq. 2's map M as a change of coordinates (Correa & Silver 2007,
// section 3.2, "to render round cuts"). A box may store its deformation texture D and its alpha
// map A over (angle, radius, height) about one of its axes through its centre, instead of over
// (x, y, z). A twist is then linear in the height alone, and a cut that follows a cylinder about
// the axis (a groove around a limb) depends on radius and height alone: a few texels of angle
// hold what a Cartesian texture needs many texels on every axis for (docs/conventions.md,
// "Cylindrical textures", and the measured table in docs/cylindrical.md).
//
// Convention, one place for the whole program (the shader's cylindrical()/cartesian() follow it):
//   a the axis, u = (a + 1) % 3, v = (a + 2) % 3 (box frame);
//   theta = atan2(x_v, x_u) in (-pi, pi],  r = sqrt(x_u^2 + x_v^2),  h = x_a.
// A cylindrical texture's grid (Grid3: origin = lower corner, texel centres half a texel in):
//   axis 0, theta: origin -pi, spacing 2 pi / n, periodic (GL_REPEAT: texels n - 1 and 0 are
//           neighbours);
//   axis 1, r:     the first texel centre on the axis (r = 0), the last at the domain's radius;
//   axis 2, h:     the first and last texel centres at the domain's ends.
// Reads beyond the grid's region along r or h hold no preimage (w = 0).
// D's texel at (theta', r', h') holds (theta - theta', r - r', h - h', w): the preimage's
// coordinates minus the point's. theta's difference is unwrapped along h (from the lowest texel,
// where it lies in (-pi, pi]), so a twist of any number of turns is linear in h; texels on the
// axis copy their angle difference from their neighbour along r (the preimage of a point on the
// axis has no angle). w = 1 wherever the inverse is finite: the ray caster's box test on the
// preimage decides validity exactly (an interpolated w would blur the box's corners over the few
// texels of angle). A's texels hold A itself.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "base/grid.h"
#include "base/interrupt.h"
#include "deformers/deformer.h"
#include "library/deformation_bake.h"
#include "library/textures.h"

namespace raywarp {

// (theta, r, h) of a box-frame point about `axis`, and back.
Eigen::Vector3d to_cylindrical(const Eigen::Vector3d& p, int axis);
Eigen::Vector3d from_cylindrical(const Eigen::Vector3d& c, int axis);

// What a cylindrical texture covers: radii [0, radius], heights [low, high]. With `faces`, the
// box's faces across the axis lie at heights face_low and face_high inside [low, high]: a
// deformation often has a kink there (a twist's angle stops at the box's ends), so the layout puts
// texel centres on them, and a texel's interpolation never straddles one.
struct CylindricalDomain {
  double radius = 0.0, low = 0.0, high = 0.0;
  bool faces = false;
  double face_low = 0.0, face_high = 0.0;
};
// The domain that holds `region` (box frame): its largest radius about `axis`, its extent along it.
CylindricalDomain cylindrical_domain(const Eigen::AlignedBox3d& region, int axis);
// The same, with the faces of the box of `half_extents` across `axis` when `region` holds them.
CylindricalDomain cylindrical_domain(const Eigen::AlignedBox3d& region, int axis,
                                     const Eigen::Vector3d& half_extents);

// The heights of a layout with n >= 2 texels over `domain`: its first texel centre and spacing.
// Without faces the first and last centres lie on low and high. With faces, on face_low and
// face_high as well: the spacing divides face_high - face_low, and whole texels pad beyond the
// faces to low and high (the last texel may lie past high); where n is too small for that, as
// without faces.
void cylindrical_heights(const CylindricalDomain& domain, int n, double* first, double* spacing);

// The grid over `domain` with `counts` texels (theta, r, h), counts >= (2, 2, 2); all `fill`.
template <typename T>
Grid3<T> cylindrical_layout(const CylindricalDomain& domain, const Eigen::Vector3i& counts,
                            const T& fill) {
  const double dr = domain.radius / (counts[1] - 1);
  double first = 0.0, dh = 0.0;
  cylindrical_heights(domain, counts[2], &first, &dh);
  const double two_pi = 2.0 * 3.14159265358979323846;
  return Grid3<T>(Eigen::Vector3d(-0.5 * two_pi, -0.5 * dr, first - 0.5 * dh),
                  Eigen::Vector3d(two_pi / counts[0], dr, dh), counts, fill);
}

inline Eigen::Matrix<double, 1, 1> texel_in_double(float x) {
  return Eigen::Matrix<double, 1, 1>(x);
}
inline Eigen::Vector4d texel_in_double(const Eigen::Vector4f& x) { return x.cast<double>(); }

// Trilinear interpolation at cylindrical coordinates c, periodic in theta (GL_REPEAT), clamped to
// the edges along r and h (GL_CLAMP_TO_EDGE), in double: GL_LINEAR's result, as Grid3::sample.
template <typename T>
auto sample_periodic(const Grid3<T>& g, const Eigen::Vector3d& c) {
  const Eigen::Vector3d u =
      (c - g.origin).cwiseQuotient(g.spacing) - Eigen::Vector3d::Constant(0.5);
  int i0[3], i1[3];
  double w[3];
  for (int a = 0; a < 3; ++a) {
    const double f = std::floor(u[a]);
    w[a] = u[a] - f;
    if (a == 0) {
      const double n = g.dims[0];
      const double wrapped = f - n * std::floor(f / n);  // in [0, n)
      i0[0] = std::clamp(static_cast<int>(wrapped), 0, g.dims[0] - 1);
      i1[0] = i0[0] + 1 == g.dims[0] ? 0 : i0[0] + 1;
    } else {
      const int base = static_cast<int>(std::clamp(f, -1.0, static_cast<double>(g.dims[a])));
      i0[a] = std::clamp(base, 0, g.dims[a] - 1);
      i1[a] = std::clamp(base + 1, 0, g.dims[a] - 1);
    }
  }
  auto v = [&](int i, int j, int k) { return texel_in_double(g.at(i, j, k)); };
  auto lerp = [](const auto& a, const auto& b, double t) { return (a * (1.0 - t) + b * t).eval(); };
  auto c00 = lerp(v(i0[0], i0[1], i0[2]), v(i1[0], i0[1], i0[2]), w[0]);
  auto c10 = lerp(v(i0[0], i1[1], i0[2]), v(i1[0], i1[1], i0[2]), w[0]);
  auto c01 = lerp(v(i0[0], i0[1], i1[2]), v(i1[0], i0[1], i1[2]), w[0]);
  auto c11 = lerp(v(i0[0], i1[1], i1[2]), v(i1[0], i1[1], i1[2]), w[0]);
  return lerp(lerp(c00, c10, w[1]), lerp(c01, c11, w[1]), w[2]);
}

// Whether cylindrical coordinates c lie in a cylindrical grid's region along r and h.
template <typename T>
bool in_cylindrical_region(const Grid3<T>& g, const Eigen::Vector3d& c) {
  return c[1] <= g.origin[1] + g.extent()[1] && c[2] >= g.origin[2] &&
         c[2] <= g.origin[2] + g.extent()[2];
}

// D and w at the box-frame point p' from a cylindrical deformation texture, in Cartesian terms:
// (preimage - p', w) with the preimage from_cylindrical(c + D(c)), c = to_cylindrical(p'); zero
// (w = 0) beyond the grid's region along r or h. The shader's deformation() does the same.
Eigen::Vector4d cylindrical_displacement(const Grid3<Eigen::Vector4f>& grid, int axis,
                                         const Eigen::Vector3d& p_def);
// A at p' from a cylindrical alpha map (its edge value beyond the region along r or h).
double cylindrical_alpha(const Grid3<float>& grid, int axis, const Eigen::Vector3d& p_def);

// D baked at the texel centres of the cylindrical grid over `domain` with `counts` texels.
DeformationTexture bake_cylindrical_deformation(const Deformer& deformer, int axis,
                                                const CylindricalDomain& domain,
                                                const Eigen::Vector3i& counts,
                                                Interrupter* interrupter = nullptr);
// A baked the same way (requires deformer.has_cut()).
AlphaMap bake_cylindrical_alpha(const Deformer& deformer, int axis, const CylindricalDomain& domain,
                                const Eigen::Vector3i& counts, Interrupter* interrupter = nullptr);

// The error of a cylindrical D as the ray caster reads it: the largest distance between the
// preimage read (cylindrical_displacement) and the exact one (deformer.inverse) over the centres
// of the texture's cells whose exact preimage lies in the box, outside the cut and a cell's reach
// of it (as deformation_texture_error, whose cells are those of a Cartesian texture).
double cylindrical_deformation_error(const Deformer& deformer, const Eigen::Vector3d& half_extents,
                                     const DeformationTexture& texture, int axis,
                                     Interrupter* interrupter = nullptr);
// The error of a cylindrical A where it places the cut face: the largest |A_read - A| over the
// cell centres with |A| < band.
double cylindrical_alpha_error(const Deformer& deformer, const AlphaMap& map, int axis, double band,
                               Interrupter* interrupter = nullptr);

// Automatic layouts, as bake_deformation_auto and bake_alpha_auto: from `floor` counts, axes
// refined by their interpolation error estimates (second differences, object units: an angle's
// difference counts at its radius) until the measured error is at most `target`, at most four
// bakes, within `budget_bytes`; the best bake is returned.
AutoDeformation bake_cylindrical_deformation_auto(const Deformer& deformer,
                                                  const Eigen::Vector3d& half_extents, int axis,
                                                  const CylindricalDomain& domain, double target,
                                                  std::uint64_t budget_bytes,
                                                  const Eigen::Vector3i& floor,
                                                  Interrupter* interrupter = nullptr);
AutoAlpha bake_cylindrical_alpha_auto(const Deformer& deformer, int axis,
                                      const CylindricalDomain& domain, double target, double band,
                                      std::uint64_t budget_bytes, const Eigen::Vector3i& floor,
                                      Interrupter* interrupter = nullptr);

// measure_inverse_residual for a cylindrical D: at its texel centres p' (valid, with the exact
// preimage in the box), |F(p) - p'| for the preimage p the texel holds.
InverseResidual measure_cylindrical_residual(const Deformer& deformer,
                                             const Eigen::Vector3d& half_extents,
                                             const DeformationTexture& texture, int axis,
                                             double tolerance, Interrupter* interrupter = nullptr);

}  // namespace raywarp
