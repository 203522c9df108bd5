// The two textures the ray caster reads, both in a box's local frame (object units).
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <optional>
#include <string>

#include "base/box.h"
#include "base/grid.h"
#include "base/interrupt.h"
#include "library/depth_cube.h"
#include "library/sampling.h"

namespace raywarp {

// Implicit surface of S_D (the part of the mesh inside the box): signed distance,
// f > 0 inside, f < 0 outside, |grad f| ~ 1, object units (docs/conventions.md#sign-of-f; OpenVDB
// gives unsigned distances only). The grid covers the box plus a margin. Within the
// narrow band of half width `band_voxels` the values are distances; beyond it they are
// +-`background` (= band_voxels * spacing), a lower bound of the true distance, so steps of
// |f| stay safe.
struct DistanceGrid {
  Grid3<float> grid;
  float background = 0.0f;
  double band_voxels = 0.0;
  std::string sign_method;  // how inside was decided, for the report
  long active_voxels = 0;   // voxels in the narrow band
  // Faces with no inside of their own, drawn as shells of this half thickness (library/sheets.h).
  long sheet_faces = 0;
  double sheet_half_thickness = 0.0;  // object units
  double sheet_area_share = 0.0;      // their area over that of all faces meeting the grid's region
  double bake_seconds = 0.0;
};

// Inverse displacement D(p') with p = p' + D(p') (deformed -> undeformed), in object units in
// the box's local frame, over the bounds of the deformed box F(box). Channel w is the validity:
// 1 where the preimage p lies in the box, 0 elsewhere (D is still finite there, never NaN).
struct DeformationTexture {
  Grid3<Eigen::Vector4f> grid;
  double bake_seconds = 0.0;
};

// Where a ray leaves a box through a face, the ray caster counts a sample within this many
// voxels of the implicit surface as a hit: the distance grid's surface may lie up to about a voxel
// inside the mesh the raster pass draws beyond the face, and a crack would show the mesh's inside.
constexpr double kSeamVoxels = 1.0;

// How a cut shows (Correa & Silver 2007, section 5.1): the surface opened as a thin shell,
// a solid with a cut face where A crosses 0 (eq. 6), or a shell of thickness tau (eq. 7).
enum class CutMode { Hollow, Solid, ThickShell };
const char* cut_mode_name(CutMode mode);

// The alpha map A(p') of a cut, A > 0 inside the cut region, in the deformed box's frame: a
// signed distance to the cut region's boundary (see Deformer::alpha), so it is also the distance
// field the ray caster skips the cut with.
struct AlphaMap {
  Grid3<float> grid;
  double bake_seconds = 0.0;
};

// The ray caster reads the distance grid this many of its voxels beyond the faces of a box whose
// deformer moves nothing (a box cut), to find the caps a removed part leaves on the box faces.
constexpr double kCapVoxels = 2.0;

// What the `bounded` tracer (render.sampling = "bounded") needs: bounds of the Lipschitz constants
// of the interpolated textures, per brick. It sphere traces
//   g(p') = min( f(p), b(p), (w(p') - 1/2) / L_w ),  p = p' + D(p'),
// where b is the signed distance to the box (> 0 inside, 1-Lipschitz) and w the validity channel
// of D: g > 0 exactly where the linear search counts a sample as inside (valid and f > 0).
// From p' (preimage p), along any segment of length s <= min(B_D, B_f / L_D(p')),
//   |g(x) - g(y)| <= L_f(p) * L_D(p') * |x - y|,
// where L_D(p') >= 1 bounds ||I + J_D|| over the brick of D holding p' and its 26 neighbours (B_D
// its shortest side), and L_f(p) >= 1 bounds |grad f| over the brick of the distance grid holding p
// and its neighbours (side B_f): p moves at most L_D s <= B_f, so it stays in those bricks, and the
// other two terms of g are at most L_D- and 1-Lipschitz. A step of |g| / (L_f L_D), no longer
// than that, therefore never passes a point where g > 0.
struct StepBounds {
  // Per brick of `brick_cells`^3 interpolation cells of D (cells lie between texel centres): a
  // bound of ||I + J_D|| of the trilinear interpolant over the brick and its 26 neighbours, at
  // least 1. origin = D's first texel centre, spacing = brick_cells * D's spacing.
  Grid3<float> bricks;
  // The same for |grad f| of the interpolated distance grid, at least 1 (box frame).
  Grid3<float> sdf_bricks;
  int brick_cells = 8;
  double sdf_lipschitz = std::numeric_limits<double>::infinity();  // |grad f|, whole grid
  double validity_lipschitz = 0.0;  // |grad w| of the interpolant (0 where w = 1 everywhere)
  bool empty() const { return bricks.data.empty() || sdf_bricks.data.empty(); }
};

// A bound of |grad| of the trilinear interpolant of a scalar grid: in a cell, d/dx is a bilinear
// blend of the cell's four x-edge differences (/ spacing), so |grad| <= sqrt(sum over axes of the
// largest edge difference squared). The largest over all cells. Clamp-to-edge adds no slope.
double interpolant_lipschitz(const Grid3<float>& grid, Interrupter* interrupter = nullptr);
// StepBounds of a box's textures, with bricks of `brick_cells` cells. Call after the textures
// take their final values (after round_textures_to_half).
StepBounds bake_step_bounds(const DistanceGrid& sdf, const DeformationTexture& deformation,
                            int brick_cells = 8, Interrupter* interrupter = nullptr);
// At p' (box frame) with preimage p = p' + D(p'): the Lipschitz bound L_f(p) L_D(p') of g, and
// the longest step it holds for, min(B_D, B_f / L_D(p')).
struct StepBound {
  double lipschitz = 0.0, longest = 0.0;
};
StepBound step_bound_at(const StepBounds& bounds, const Eigen::Vector3d& p_def,
                        const Eigen::Vector3d& p);

// Everything the ray caster needs for one box.
struct BoxTextures {
  Box box;
  // The implicit surface: the distance grid, or (uses_depth_cube) the depth-map cube, whose
  // `sdf` then holds no texels (see implicit_spacing, implicit_background, implicit_value).
  DistanceGrid sdf;
  DepthCube depth_cube;
  bool uses_depth_cube = false;
  DeformationTexture deformation;
  // Where rays are cast, in the box frame: the deformation texture's region, or for a deformer
  // that moves nothing the box grown by kCapVoxels voxels (within the distance grid).
  Eigen::AlignedBox3d region;
  // D = 0 everywhere: the shader reads no deformation texture and treats samples just beyond
  // the box (after a sample inside it) as their own preimage.
  bool moves_nothing = false;
  // A bound of ||I + J_D|| of the interpolated texture over its cells outside the cut: the
  // Lipschitz constant of p' -> p' + D(p'), for empty-space skipping (1 when D = 0). Unknown
  // (infinite) by default, which turns skipping by the distance grid off.
  double lipschitz = std::numeric_limits<double>::infinity();
  // Cuts.
  bool has_cut = false;
  CutMode cut_mode = CutMode::Solid;
  double shell_thickness = 0.0;  // tau, object units (thick shell)
  AlphaMap alpha;                // empty unless has_cut
  // Lipschitz bounds for the `bounded` tracer; empty unless that sampling is used.
  StepBounds step_bounds;
  // The affine map M of eq. 2 between the box frame and the deformation texture's frame: D is
  // read at M p' (identity: at p'). Correa & Silver animate a deformation by moving M alone,
  // with no re-bake (Fig. 4): a twist scaled along its axis about its fixed face is a twist of
  // a smaller angle. Not with the `bounded` tracer, whose step bounds are baked for M = I.
  Eigen::Matrix4d texture_map = Eigen::Matrix4d::Identity();
  // >= 0: D and A are stored over (angle, radius, height) about this axis of the box frame
  // through its centre (library/cylindrical.h); -1: over (x, y, z). Not with a texture map M.
  int cylindrical_axis = -1;
  bool cylindrical() const { return cylindrical_axis >= 0; }
  // Textures stored as 16-bit floats on the GPU (their values already rounded to half precision
  // by round_to_half, so the CPU reference reads what the GPU does).
  bool half_precision = false;
};

// The one place that decides whether a box is sphere traced with Lipschitz-bounded steps: the
// scene asks for render.sampling "bounded" and the box's deformation is continuous and moves
// something (a cut's D jumps, so no Lipschitz bound holds across it; a box cut moves nothing).
// The bake then bakes the box's StepBounds, and the renderer picks the bounded shader variant.
bool traces_bounded(Sampling sampling, bool has_cut, bool moves_nothing);

// x rounded to the nearest IEEE half-precision value (ties to even), as a float; magnitudes
// beyond the largest half (65504) are clamped to it, so the result stays finite.
float round_to_half(float x);
// Rounds every texel of the box's textures to half precision and sets half_precision.
void round_textures_to_half(BoxTextures& b);

// The implicit's voxel, the unit of steps, thresholds, the seam tolerance and the normals'
// differences: the distance grid's voxel, or the depth maps' texel.
double implicit_spacing(const BoxTextures& b);
// |f| the ray caster gives a sample outside the box's preimage (more than kSeamVoxels voxels):
// the distance grid's background, or the depth cube's far depth.
double implicit_background(const BoxTextures& b);
// The preimage p' + D(M p') of a deformed point p' (object space), D read from the box's
// deformation texture as the ray caster reads it (trilinear, valid where w >= 1/2): the point of
// the undeformed mesh that shows at p'. None where the texture holds no preimage (outside its
// grid, or w < 1/2); p' itself inside a box that moves nothing.
std::optional<Eigen::Vector3d> texture_preimage(const BoxTextures& b, const Eigen::Vector3d& p);

// The steps of the central differences of D and A (normals, the jacobian step, the cut face's
// gradient), per axis of the box frame, and of the band by the box faces where sample_at lets a
// falling w pass: D's and A's texel sides, or for cylindrical textures the shorter of their radius
// and height sides on every axis (their angle's side is no length).
Eigen::Vector3d deformation_step(const BoxTextures& b);
Eigen::Vector3d alpha_step(const BoxTextures& b);

// f at p (box frame): the distance grid sampled trilinearly, or depth_cube_value.
double implicit_value(const BoxTextures& b, const Eigen::Vector3d& p);

// Where rays are cast for a box: `region`, or the deformation texture's region when unset.
Eigen::AlignedBox3d ray_cast_region(const BoxTextures& b);
// How far from the cut empty-space skipping by the distance grid stops:
// sqrt(3) (alpha texel + deformation texel / 2), covering the alpha map's interpolation error
// and the cells of D next to the cut (see shaders/march.glsl).
double cut_margin(const BoxTextures& b);
// Whether empty-space skipping can pay for a box when the scene asks for it (`requested`): inside
// a cut it always can; by the distance grid only where the longest skip, background /
// (sqrt(3) lipschitz), exceeds the linear-search step (a twist's |I + J_D| is large enough that
// it never does, and the skip's arithmetic would only cost). A depth cube's |f| is no distance
// bound: there only skipping inside a cut pays.
bool skipping_pays(const BoxTextures& b, double step_voxels, bool requested);

}  // namespace raywarp
