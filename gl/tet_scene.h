// The tetrahedral route for a whole scene (render.route "tets"): the mesh outside the boxes
// rasterised by gl::Renderer with its ray casts off, and each simulation box's body walked by a
// gl::TetRenderer in the scene's display mode, composited per pixel by depth (composite_nearest).
// The volume mode composites over the background colour, so the mesh behind a translucent body
// does not show through it. Needs a current gl::Context.
#pragma once
#include <cstddef>
#include <memory>
#include <vector>

#include "gl/renderer.h"
#include "gl/tet_render.h"
#include "library/tet_body.h"

namespace raywarp::gl {

struct TetSceneStats {
  double raster_ms = 0.0;  // the mesh outside the boxes
  double walk_ms = 0.0;    // the tetrahedral walks of every box
  TetWalkStats walk;       // of the last box
};

class TetSceneRenderer {
 public:
  // `boxes` are the scene's boxes (their frames discard the mesh inside them), `bodies` one per
  // box. Volume mode: builds each box's pre-integration table (the scene's transfer function, or
  // default_transfer_function over the body's scalar). Throws Error when the counts differ.
  TetSceneRenderer(const Mesh& mesh, const std::vector<const BoxTextures*>& boxes,
                   const std::vector<const TetBody*>& bodies, const TetDisplaySpec& spec);
  ~TetSceneRenderer();
  TetSceneRenderer(const TetSceneRenderer&) = delete;
  TetSceneRenderer& operator=(const TetSceneRenderer&) = delete;

  Image render(const Camera& camera, int width, int height, const RenderSettings& settings,
               TetSceneStats* stats = nullptr);
  // GPU bytes of the bodies (TetRenderer::mesh_bytes) and of the tables.
  std::size_t mesh_bytes() const;
  std::size_t table_bytes() const;
  double table_seconds() const;  // building the tables
  long tet_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace raywarp::gl
