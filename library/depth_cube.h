// The depth-map cube (Correa & Silver 2007, section 6.1): an implicit representation of S_D, the
// part of the mesh inside a box, by six depth maps, one per box face, each looking inward along
// the face's normal (orthographic). It takes 6 maps of n^2 texels where a distance grid takes n^3
// voxels, but it is exact only for shapes whose every surface point is seen by some face along
// an axis (see docs/depth_cube.md for where it fails).
//
// Map k (face -x, +x, -y, +y, -z, +z for k = 0..5; axis a = k / 2) holds, per texel of a grid
// over the face with `resolution` texels along the box's longest side (the same spacing on every
// face), H_k = the depth (object units, from the face plane, along the inward normal) of the first
// surface point inside the box on the ray through the texel centre. Where the ray meets no
// surface inside the box and starts outside the mesh, H_k = far_depth, 1024 box lengths beyond
// the face (or, next to texels that see the surface, the deepest of their depths: a one-texel
// dilation); where it starts inside the mesh, H_k = -far_depth (the face is no surface of the
// mesh there). DepthCube::far_depth says why. With d_k(p) the distance of p from face k's plane
// (positive inward),
//   f_k(p) = d_k(p) - H_k(p_uv)   (> 0 beyond the first surface: raywarp's sign, f > 0 inside),
//   f(p)   = rho * min_k |f_k(p)|,  rho = +1 iff f_k(p) > 0 for all six faces, else -1,
// H read bilinearly with clamp-to-edge at texel centres (GL_LINEAR semantics).
// Inside is exact where every point of the surface is seen by some face; a pocket hidden from all
// six faces counts as inside. |f| is the distance along an axis to a surface point: up to the
// interpolation of H an upper bound of the Euclidean distance, and no lower bound, so skipping
// empty space by |f| is unsafe, and the renderer does not.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "base/box.h"
#include "base/interrupt.h"
#include "library/mesh.h"

namespace raywarp {

// far_depth in box lengths (see DepthCube::far_depth).
constexpr double kFarDepthBoxes = 1024.0;

// One face's depth map, in the box's local frame.
struct DepthMap {
  int axis = 0;   // the face's normal axis
  int side = -1;  // -1: the face at -h[axis], looking along +axis; +1: at +h[axis], along -axis
  int u_axis = 1, v_axis = 2;  // the texel grid's axes on the face: the other two, increasing
  double half_extent = 1.0;    // the box's half extent along `axis`: the face lies at side * it
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // lower corner of the grid, (u, v)
  double spacing = 1.0;                              // texel side, object units
  int nu = 0, nv = 0;                                // texels along u and v
  std::vector<float> depth;                          // H, nu * nv texels, u fastest

  float at(int i, int j) const { return depth[static_cast<size_t>(j) * nu + i]; }
  // H at (u, v) (local coordinates along u_axis, v_axis): bilinear between texel centres
  // (i + 0.5) * spacing, clamped to the outer centres: GL_LINEAR with GL_CLAMP_TO_EDGE.
  double sample(double u, double v) const;
  // d_k(p): the distance of p (local frame) from the face's plane, positive inward.
  double distance_from_face(const Eigen::Vector3d& p) const;
};

// Counts of the texels of the six maps, for the bake's report.
struct DepthCubeTexels {
  long surface = 0;            // H = the depth of a surface point
  long inside = 0;             // H = -far_depth: the ray starts inside the mesh
  long empty = 0;              // no surface inside the box: H = far_depth, or dilated (below)
  long dilated = 0;            // empty texels next to the surface that took a neighbour's depth
  long winding_fallbacks = 0;  // inside decided by the generalised winding number (open mesh)
};

struct DepthCube {
  Eigen::Vector3d half_extents = Eigen::Vector3d::Ones();  // the box's
  double spacing = 0.0;                                    // texel side of every map
  // |H| where a ray meets no surface inside the box: kFarDepthBoxes box lengths (2 max(h) each),
  // far beyond every face's depth range. An empty ray (H = +far_depth) votes outside all along,
  // one that starts inside the mesh (H = -far_depth) inside all along, and neither enters the min
  // of |f_k|. Three choices follow from H being interpolated:
  //  - That far: between the last texel centre that sees the surface and an empty one, H blends
  //    the rim's depth with the empty value, so f_k = 0 on a sheet behind the rim (a "skirt"
  //    where |f| is near 0 far from any surface, which catches the ray caster's seam test and
  //    threshold refinement). At this distance the sheet is 1/1024 of a texel wide.
  //  - Dilated by a texel: an empty texel next to (8-neighbourhood) texels that see the surface
  //    takes the deepest of their depths. Otherwise each map's silhouette would end at its last
  //    covered texel centres, eroding S_D by up to a texel's diagonal, and since a point is inside
  //    only where all six faces agree, an erosion in any one map is an error. A dilation is
  //    trimmed by the maps that see the surface there (some axis lies within 55 degrees of any
  //    normal, and the silhouette of one map is seen face-on by another).
  //  - -far_depth rather than 0 where a ray starts inside: with H = 0, |f_k| = d_k, the distance to
  //    the face, would be the min near a face the mesh crosses and bend the normals there (a
  //    visible line along the seam), and f would turn negative just beyond the face, where a box
  //    cut's caps are looked for.
  float far_depth = 0.0f;
  std::array<DepthMap, 6> maps;  // -x, +x, -y, +y, -z, +z
  DepthCubeTexels texels;
  double bake_seconds = 0.0;

  bool empty() const { return maps[0].depth.empty(); }
  // The texture layout, on raywarp's GPU and in exports alike: one 3D texture of width x height
  // x 8 texels (the largest map's u and v counts), map k in slice k, in its lower corner, the
  // rest of the slice repeating the map's last column and row (clamp to edge within the map).
  // Eight slices, not six (7 and 8 repeat the last map), so that slice k's centre, texture
  // coordinate (k + 0.5) / 8, is exact in binary: a read there mixes in no other map however the
  // sampler rounds, which (k + 0.5) / 6 would not ensure.
  struct Layers {
    int width = 0, height = 0;
    static constexpr int kDepth = 8;
  };
  Layers layers() const;
  // The texture's texels, width x height x 8, u fastest, then v, then the slice.
  std::vector<float> layer_texels() const;
  // Sets the maps' depths from such texels; their layouts (nu, nv, ...) must be set already.
  void set_depths_from_layers(const std::vector<float>& texels);
  // Bytes of the texture at `bytes_per_texel` (4 for R32F, 2 for R16F).
  std::uint64_t texture_bytes(int bytes_per_texel = 4) const;
  // Texels of the six maps themselves (without the array's padding).
  long map_texels() const;
};

// Texels along each local axis for a box of `half_extents` with `resolution` texels along its
// longest side: max(1, ceil(2 h_a / spacing)), spacing = 2 max(h) / resolution.
Eigen::Vector3i depth_cube_dims(const Eigen::Vector3d& half_extents, int resolution);
// Bytes of the float texture of such a depth cube (DepthCube::layers; before anything is
// allocated).
std::uint64_t depth_cube_bytes(const Eigen::Vector3d& half_extents, int resolution);

// A depth cube's layout for a box of `half_extents` at `resolution` (spacing, far_depth, each
// map's axes, origin and texel counts), every texel far_depth: what bake_depth_cube fills, and
// what an exported cube's atlas is read into. Error for a resolution outside [1, 65536].
DepthCube depth_cube_layout(const Eigen::Vector3d& half_extents, int resolution);

// Bakes the depth cube of `mesh` over `box` on the CPU: each triangle is rasterised into the
// texel grid of each axis (orthographic projection: drop the axis; the depth by barycentrics at
// texel centres, with a top-left rule so that a ray through a shared edge meets it once), which
// is O(triangles + texels). Whether a ray starts inside the mesh is decided by the facing of its
// first hit inside the box, or, with no hit inside, by the signed crossings before the face
// (the same from both faces on a closed mesh; where they differ, the mesh is open along that
// line and the generalised winding number at the face point decides). Throws Error for a
// resolution outside [1, 65536]. In parallel by bands of texel rows; `interrupter`, when given, is
// polled throughout and told the progress of stage "depth cube" (Cancelled when cancelled).
DepthCube bake_depth_cube(const Mesh& mesh, const Box& box, int resolution,
                          Interrupter* interrupter = nullptr);

// f(p) at p in the box's local frame, exactly as shaders/march.glsl's distance_at with
// RAYWARP_IMPLICIT 1 (in double).
double depth_cube_value(const DepthCube& cube, const Eigen::Vector3d& p_box);

// One line for the log: maps, texel, memory, texel counts, bake time.
std::string describe(const DepthCube& cube);

}  // namespace raywarp
