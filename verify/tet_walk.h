// The CPU mirror, in double, of ray casting a (deformed) tetrahedral mesh by walking its
// tetrahedra (Tejada & Ertl 2005, section 5; docs/tet_walk.md).
//
// A ray o + t r (r unit length, t in object units) enters the mesh at the nearest boundary face
// it meets from outside (a front face: r · n < 0, n the face's outward normal), found through a
// TriangleBvh over the boundary faces. In tetrahedron t, entered through face e at t_in, the exit
// face is the face k != e with r · n_k > 0 (not visible) and the smallest
// λ_k = (v_{3-k} - o) · n_k / (r · n_k) (Tejada & Ertl 2005, section 5.1); λ_k must not lie
// behind t_in (by more than a rounding tolerance), and t_out = max(λ_k, t_in). The walk steps to
// the neighbour across face k. When face k is on the boundary the ray leaves the mesh; it
// re-enters a non-convex mesh at the next front boundary face strictly beyond the exit point:
// each stretch from an entry to an exit is a "section" (the depth-peeling passes of the GL
// renderer). The scalar at both ends of the segment is s(x) = g_t · x + ĝ_t.
//
// Robustness: a ray takes at most step_cap() = 4 T + 1000 tetrahedron steps over all its
// sections (T tetrahedra) and is reported "capped" when it reaches the cap. A degenerate
// tetrahedron (TetGeometry flag), or one where no face qualifies as the exit, ends the section at
// t_in ("lost"); the walk goes on from the next front boundary face beyond it. Boundary faces of
// degenerate tetrahedra have zero normals and are never entered. Inverted tetrahedra are walked as
// the geometric simplices they are (their normals point away from the opposite vertex).
#pragma once
#include <Eigen/Core>
#include <array>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "library/camera.h"
#include "library/image.h"
#include "library/preintegration.h"
#include "library/scene.h"
#include "library/tet_mesh.h"

namespace raywarp {

class TriangleBvh;

// A tetrahedral mesh in one state, ready to walk: the topology (built once), the geometry of the
// state and a BVH over the boundary faces. Positions are in the frame the rays are given in
// (object space for a camera: a SimulationBody's nodes are in its box's frame, so map them by
// Box::to_object first).
class TetWalkMesh {
 public:
  // Builds the topology (tet_topology: throws Error on bad tetrahedra) and the state.
  TetWalkMesh(std::vector<std::array<int, 4>> tets, std::vector<Eigen::Vector3d> positions,
              std::vector<double> scalar);
  // With a topology built before (checked only for its sizes, so that a corrupted one can be
  // walked: the step cap is what stops it).
  TetWalkMesh(TetTopology topology, std::vector<std::array<int, 4>> tets,
              std::vector<Eigen::Vector3d> positions, std::vector<double> scalar);
  ~TetWalkMesh();
  TetWalkMesh(TetWalkMesh&&) noexcept;
  TetWalkMesh& operator=(TetWalkMesh&&) noexcept;

  // A new state (after a simulation step): recomputes the geometry (tet_geometry) and the
  // boundary BVH. `scalar` empty: zero.
  void set_state(std::vector<Eigen::Vector3d> positions, std::vector<double> scalar);

  const TetTopology& topology() const { return topology_; }
  const TetGeometry& geometry() const { return geometry_; }
  const std::vector<std::array<int, 4>>& tets() const { return tets_; }
  const std::vector<Eigen::Vector3d>& positions() const { return positions_; }
  const std::vector<double>& scalar() const { return scalar_; }
  // The tree over the boundary faces of non-degenerate tetrahedra; its triangle i is boundary
  // face bvh_faces()[i] (an index into topology().boundary).
  const TriangleBvh& boundary_bvh() const { return *bvh_; }
  const std::vector<int>& bvh_faces() const { return bvh_faces_; }
  int tet_count() const { return static_cast<int>(tets_.size()); }
  // The most tetrahedron steps one ray may take, over all its sections: 4 T + 1000.
  long step_cap() const { return 4L * tet_count() + 1000; }
  // The diagonal of the positions' bounds (the scale of the rounding tolerances).
  double diagonal() const { return diagonal_; }

 private:
  void build_state();
  TetTopology topology_;
  std::vector<std::array<int, 4>> tets_;
  std::vector<Eigen::Vector3d> positions_;
  std::vector<double> scalar_;
  TetGeometry geometry_;
  std::unique_ptr<TriangleBvh> bvh_;
  std::vector<int> bvh_faces_;
  double diagonal_ = 0.0;
};

// The part of a ray inside one tetrahedron.
struct TetSegment {
  int tet = -1;
  int section = 0;      // 0 for the first entry into the mesh, 1 for the next, ...
  int entry_face = -1;  // local face of `tet` the ray came in through
  int exit_face = -1;   // local face it leaves through (-1: clipped at t_max)
  double t_in = 0.0, t_out = 0.0;
  double s_in = 0.0, s_out = 0.0;  // the scalar at both ends, from tet's gradient
  bool first_in_section = false;
};

// One section: from an entry through a front boundary face to an exit through a boundary face
// (or to t_max, or where the walk was lost or stopped).
struct TetSection {
  double t_in = 0.0, t_out = 0.0;
  TetFace entry, exit;  // exit.tet = -1 when it did not end on a boundary face
};

struct TetWalkResult {
  int sections = 0;
  long steps = 0;        // tetrahedron steps over all sections
  bool capped = false;   // stopped by step_cap()
  int lost = 0;          // sections ended in a degenerate tetrahedron or with no exit face
  bool stopped = false;  // the visitor asked to stop (a hit, or early termination)
  std::vector<TetSection> section_list;
};

// Walks the ray o + t r (r unit) over [t_min, t_max], calling visit for every segment in order;
// visit returns false to stop the walk.
TetWalkResult walk_ray(const TetWalkMesh& mesh, const Eigen::Vector3d& origin,
                       const Eigen::Vector3d& direction, double t_min, double t_max,
                       const std::function<bool(const TetSegment&)>& visit);

// Surface mode: the surface is where the per-vertex scalar f (> 0 inside) is 0; f is linear in
// each tetrahedron, so the crossing is solved exactly: t = -(g · o + ĝ) / (g · r), within the
// segment. The hit is the first point where f goes from <= 0 to > 0, comparing the scalar at the
// end of the previous segment with the one at the end of the current segment (so rounding between
// neighbouring tetrahedra cannot miss a crossing); its normal is -g_t / |g_t|.
struct SurfaceOptions {
  // The ray entering the mesh where f > 0 is a hit at the entry point, with the boundary face's
  // outward normal (f counts as <= 0 outside the mesh). false: such a section needs f <= 0
  // within the mesh before a crossing counts.
  bool hit_where_entering_inside = true;
};
struct TetSurfaceHit {
  double t = 0.0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit, outward from f > 0
  int tet = -1;
  bool at_entry = false;  // on the mesh boundary (hit_where_entering_inside)
};
std::optional<TetSurfaceHit> surface_hit(const TetWalkMesh& mesh, const Eigen::Vector3d& origin,
                                         const Eigen::Vector3d& direction, double t_min,
                                         double t_max, const SurfaceOptions& options = {},
                                         TetWalkResult* walk = nullptr);

// Volume mode: the mesh's scalar through a transfer function, each segment's pre-integrated
// colour and opacity looked up by (s_in, s_out, t_out - t_in) and composited front to back,
// stopping once the opacity reaches `termination`. `tf` must be valid (TransferFunction::validate;
// render_tet_volume checks it).
struct VolumeOptions {
  const PreintegrationTable* table = nullptr;  // nullptr: preintegrate_exact per segment
  int exact_panels = 64;                       // preintegrate_exact's panels per segment
  double termination = 0.99;                   // early ray termination at this opacity
};
struct TetVolumeSample {
  SegmentColour colour;  // associated colour and opacity of the whole ray
  double first_entry = std::numeric_limits<double>::infinity();  // t of the first entry
};
TetVolumeSample volume_integral(const TetWalkMesh& mesh, const TransferFunction& tf,
                                const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                double t_min, double t_max, const VolumeOptions& options = {},
                                TetWalkResult* walk = nullptr);

// What a whole image's walks took.
struct TetRenderStats {
  long rays = 0;
  long entered = 0;                      // rays with at least one section
  long hits = 0;                         // surface mode: rays with a hit
  std::vector<long> sections_histogram;  // [n]: rays with n sections
  int max_sections = 0;
  long max_steps = 0;
  long total_steps = 0;
  long capped = 0;  // rays stopped by the step cap
  long lost = 0;    // sections lost (degenerate tetrahedra, no exit face)
  double seconds = 0.0;
};

// Surface mode for every pixel of a W × H image (row 0 at the top, one ray through each pixel's
// centre: Camera::pixel_ray, over its near and far planes): a hit is shaded like the other CPU
// references (headlight, albedo settings.colour · (0.2 + 0.8 max(0, n · -r)),
// docs/conventions.md#colour) with depth Camera::depth_of(hit); elsewhere settings.background and
// +inf. Throws Error on a size outside [1, 8192].
Image render_tet_surface(const TetWalkMesh& mesh, const Camera& camera, int width, int height,
                         const RenderSettings& settings, const SurfaceOptions& options = {},
                         TetRenderStats* stats = nullptr);

// Volume mode for every pixel: the ray's colour C + (1 - α) background (linear RGB, then sRGB
// bytes); depth is the depth of the ray's first entry into the mesh, +inf where it never enters.
Image render_tet_volume(const TetWalkMesh& mesh, const TransferFunction& tf, const Camera& camera,
                        int width, int height, const Eigen::Vector3d& background,
                        const VolumeOptions& options = {}, TetRenderStats* stats = nullptr);

}  // namespace raywarp
