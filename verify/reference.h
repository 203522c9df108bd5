// Independent references for raywarp's GL renders.
//
// 1. reference_render: the same ray cast as shaders/march.glsl, on the CPU in double,
//    reading the same textures through Grid3::sample (GL_LINEAR semantics), composited with a
//    CPU rasterisation of the mesh outside the boxes. It checks the shader against its
//    specification.
// 2. ground_truth_mesh + rasterize: no textures and no box logic at render time: the mesh finely
//    subdivided, split at the box faces, the inside part mapped by the exact forward map, then
//    rasterised with a z-buffer. It checks the whole method against the exact deformed surface.
#pragma once
#include <functional>
#include <optional>
#include <vector>

#include "library/camera.h"
#include "library/image.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "library/textures.h"

namespace raywarp {

// What a ray-cast hit lies on: the object's surface, the inside of its shell (seen through a
// cut), or a solid cut face.
enum class HitKind { Surface, Inside, CutFace };

// A ray-cast hit in the box's local frame.
struct RayHit {
  double t = 0.0;          // along the local ray (unit direction: same as object units)
  Eigen::Vector3d point;   // deformed position p'
  Eigen::Vector3d normal;  // unit normal facing out of what was hit (eq. 5, or grad A: eq. 6)
  HitKind kind = HitKind::Surface;
};

// The ray cast of one box along a local-frame ray over [t0, t1], exactly as the shader does it.
std::optional<RayHit> ray_cast_box(const BoxTextures& box, const Eigen::Vector3d& origin,
                                   const Eigen::Vector3d& direction, double t0, double t1,
                                   const RenderSettings& settings);

// Eq. 4's step, as the shader's `jacobian` sampling takes it: ds / |(I + J_D) v| at p_def
// (box frame) for the unit ray direction v, J_D v by a central difference of the deformation
// texture along v at its spacing, |(I + J_D) v| clamped to [1/4, 16].
double jacobian_step(const BoxTextures& box, const Eigen::Vector3d& p_def, const Eigen::Vector3d& v,
                     double ds);

Image reference_render(const Mesh& mesh, const std::vector<BoxTextures>& boxes,
                       const Camera& camera, int width, int height, const RenderSettings& settings);

// The mesh with every triangle that meets `box` split at the box faces and subdivided so that
// its edges are shorter than `max_edge`; the pieces inside the box are mapped by
// `forward_local` (the deformer's F in the box's local frame). Pieces outside are unchanged.
// With split_axis >= 0 the inside pieces are also split at the plane q[split_axis] = split_at,
// and each piece is mapped as the limit from its own side (F evaluated 1e-9 box sizes off the
// plane): the ground truth of a deformer that cuts along that plane (an incision at 0, a peel
// at its cut plane).
Mesh ground_truth_mesh(const Mesh& mesh, const Box& box,
                       const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& forward_local,
                       double max_edge, int split_axis = -1, double split_at = 0.0);

// Exact render of the mesh with a convex region of `box` removed (a box cut: no displacement),
// independent of every grid: per pixel, the mesh's triangles along the ray (all of them, through
// a BVH) and the ray's interval in the region (clipped by its half-spaces, box-local frame).
//  - Hollow: the first triangle hit that lies outside the region (a back face is the inside).
//  - Solid: the first point inside the mesh and outside the region (CSG difference): the first
//    hit outside the region, or the point where the ray leaves the region if that point lies
//    inside the mesh (odd number of hits beyond it), which is then on a cut face.
// The mesh must be closed and oriented outwards. Thick shells have no exact form here.
Image exact_cut_render(const Mesh& mesh, const Box& box, const std::vector<HalfSpace>& region,
                       CutMode mode, const Camera& camera, int width, int height,
                       const RenderSettings& settings);

// A removed region by its intervals along a ray: each (t0, t1) lies in the region, which the ray
// leaves at t1 through a face of outward normal exit_normal (box-local frame; t1 = +inf: it does
// not leave).
struct RegionInterval {
  double t0, t1;
  Eigen::Vector3d exit_normal;
};
using RegionIntervals = std::function<std::vector<RegionInterval>(
    const Eigen::Vector3d& origin_local, const Eigen::Vector3d& dir_local)>;
// exact_cut_render for any removed region given by its intervals along each ray (hollow: the
// first hit outside them; solid: or the earliest exit inside the mesh).
Image exact_removed_render(const Mesh& mesh, const Box& box, const RegionIntervals& intervals,
                           CutMode mode, const Camera& camera, int width, int height,
                           const RenderSettings& settings);
// The intervals of a groove's removed region (a ring about `axis` through the box centre: r >=
// radius and |x_axis| <= width / 2, box-local), solved from the quadratic of the cylinder and the
// slab's planes: deformers/groove.h's region, independent of its alpha.
std::vector<RegionInterval> groove_intervals(int axis, double radius, double width,
                                             const Eigen::Vector3d& origin_local,
                                             const Eigen::Vector3d& dir_local);

// CPU z-buffer rasterisation of all triangles, shaded like the GL renderer (flat colour from
// the face normal), depth as docs/conventions.md#depth. Pixel centres sampled, row 0 at the top.
Image rasterize(const Mesh& mesh, const Camera& camera, int width, int height,
                const RenderSettings& settings);

}  // namespace raywarp
