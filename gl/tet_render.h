// Ray casting a deformed tetrahedral mesh by walking its tetrahedra on the GPU (Tejada & Ertl
// 2005, section 5; docs/tet_render.md): the GL twin of the CPU mirror in verify/tet_walk.h, with
// the same rules (entry at front boundary faces, exit face by the smallest λ of the faces turned
// away from the ray, sections, the step cap 4 T + 1000 per ray, the surface and volume modes).
//
// GPU data, OpenGL 4.5 core (OSMesa/llvmpipe and EGL alike; 2D textures read by texelFetch, no
// SSBOs or texture buffers; no entry point beyond gl/gl_api.h). Tetrahedron t is texel
// (t % kTextureWidth, t / kTextureWidth) of every per-tetrahedron texture, node i the same texel
// of the node texture:
//  - static (set_mesh): the tetrahedra's nodes (RGBA32I), their neighbours packed with the
//    neighbour's face, 4 n + f, -1 on the boundary (RGBA32I), the boundary faces' (tet, face)
//    (RG32I, by boundary face) and the boundary faces' node triples as an element buffer;
//  - per state (set_state): the nodes' positions, less the centre of their bounds, with the
//    scalar in w (RGBA32F); then one fragment per tetrahedron computes its four face planes
//    (unit outward normal, offset) and its gradient (g, ĝ) into five RGBA32F render targets.
// A frame peels the ray into sections: per pass, the front boundary faces strictly beyond where
// the pixel's previous section ended are rasterised (the nearest one wins the depth test; an
// occlusion query says whether any pixel got one), then a full-screen pass walks that section
// from the entry tetrahedron. Passes stop when none wrote, or at the pass cap. Needs a current
// gl::Context.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <memory>
#include <vector>

#include "gl/renderer.h"
#include "library/camera.h"
#include "library/image.h"
#include "library/preintegration.h"
#include "library/scene.h"

namespace raywarp::gl {

// What one frame's walks took (read back from the per-pixel state after the frame; not timed).
struct TetWalkStats {
  int passes = 0;                 // depth-peeling passes that walked a section
  bool pass_cap_reached = false;  // entries remained after the last allowed pass
  long rays = 0;                  // pixels
  long entered = 0;               // rays with at least one section
  long hits = 0;                  // surface mode: rays with a hit
  long capped = 0;                // rays stopped by the step cap
  int max_sections = 0;
  std::vector<long> sections_histogram;  // [n]: rays with n sections
  long max_steps = 0, total_steps = 0;
};

// The per-state geometry as the GPU computed it, read back (float).
struct TetGpuGeometry {
  std::vector<std::array<Eigen::Vector4f, 4>> plane;  // (unit outward normal, offset) per face
  std::vector<Eigen::Vector4f> gradient;              // (g, ĝ)
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();   // the frame's origin in object space
};

class TetRenderer {
 public:
  static constexpr int kTextureWidth = 1024;
  static constexpr int kDefaultPassCap = 16;
  TetRenderer();
  ~TetRenderer();
  TetRenderer(const TetRenderer&) = delete;
  TetRenderer& operator=(const TetRenderer&) = delete;

  // Builds the topology (tet_topology: throws Error on bad tetrahedra) and uploads it; set_state
  // must follow before a render. Throws Error when a texture would exceed the context's size.
  void set_mesh(const std::vector<std::array<int, 4>>& tets, int node_count);
  // A state: one position per node (in the frame the camera sees: object space) and one scalar
  // per node (empty: zero). Uploads them and recomputes the planes and gradients on the GPU.
  // Throws Error on a size mismatch.
  void set_state(const std::vector<Eigen::Vector3d>& positions, const std::vector<double>& scalar);

  // Surface mode (f = the scalar, > 0 inside): the first crossing of f from <= 0 to > 0 (entering
  // the mesh where f > 0 is a hit on the boundary face), shaded with the headlight of
  // docs/conventions.md#colour (albedo settings.colour), linear depth; background and +inf
  // elsewhere.
  Image render_surface(const Camera& camera, int width, int height, const RenderSettings& settings,
                       FrameStats* stats = nullptr, TetWalkStats* walk = nullptr);
  // Volume mode: each segment's (s_in, s_out, length) looked up in `table` (a 3D RGBA32F texture,
  // hardware trilinear, node i at texel centre (i + 0.5) / N as PreintegrationTable::lookup
  // places it; uploaded by every call, before the frame's timing starts), composited front to
  // back until the opacity reaches 0.99; colour C + (1 - α) background (sRGB), depth of the first
  // entry, +inf where the ray never enters.
  Image render_volume(const Camera& camera, int width, int height, const PreintegrationTable& table,
                      const Eigen::Vector3d& background, FrameStats* stats = nullptr,
                      TetWalkStats* walk = nullptr);

  // The most depth-peeling passes a frame takes (default kDefaultPassCap), in [1, 1024].
  void set_pass_cap(int passes);
  int pass_cap() const;
  // The planes and gradients of the current state as computed by the GPU.
  TetGpuGeometry geometry();
  int tet_count() const;
  // Bytes of GPU memory the mesh and its state hold (the textures as allocated, rows of
  // kTextureWidth, and the element buffer); the pre-integration table and the per-image targets
  // are apart.
  std::size_t mesh_bytes() const;
  long step_cap() const { return 4L * tet_count() + 1000; }
  // Milliseconds of set_state's GPU update pass (draw to glFinish), the last time.
  double update_milliseconds() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace raywarp::gl
