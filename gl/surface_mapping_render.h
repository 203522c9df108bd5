// The object-space peer of the image-space route (docs/surface_mapping.md): the detailed mesh,
// bound to the coarse body's boundary surface (library/surface_mapping.h), moved by a vertex
// shader that evaluates eq. 9 of Mosegaard & Sørensen 2006 per vertex, and rasterised.
//
// GPU data, OpenGL 4.5 core (OSMesa/llvmpipe and EGL alike; no entry point beyond gl/gl_api.h):
//  - per vertex, static: (triangle, u, v) as floats (a triangle index is exact in a float below
//    2^24), the offset's and the rest normal's frame coordinates: 9 floats;
//  - per frame: a 2D RGBA32F texture of the coarse surface's nodes only (§3.1: "we transfer only
//    nodes that are part of the surface"), texel 2i the position of surface node i and 2i + 1 its
//    unit area-weighted normal (node_normals, computed on the CPU in double; the triangle basis
//    does not read it); kTextureWidth texels a row;
//  - static: a 2D RGBA32I texture of each boundary triangle's three surface-node numbers.
// The fragments are shaded by shaders/raster.frag.glsl with no box, as gl::Renderer shades the
// plain mesh, and write the same colour and linear-depth attachments, so an image compares with
// the ray-cast one pixel by pixel (same camera conventions, library/camera.h). Needs a current
// gl::Context.
#pragma once
#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "gl/renderer.h"
#include "library/camera.h"
#include "library/image.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "library/surface_mapping.h"

namespace raywarp::gl {

// The GLSL file of the mapping's vertex shader (its text; #include "camera.glsl"). With
// RAYWARP_READBACK defined it places vertex i on pixel (i % kTextureWidth, i / kTextureWidth)
// of a float framebuffer instead of projecting it.
const std::string& surface_mapping_vertex_glsl();

class SurfaceMappingRenderer {
 public:
  static constexpr int kTextureWidth = 1024;
  SurfaceMappingRenderer();
  ~SurfaceMappingRenderer();
  SurfaceMappingRenderer(const SurfaceMappingRenderer&) = delete;
  SurfaceMappingRenderer& operator=(const SurfaceMappingRenderer&) = delete;

  // Uploads the binding's per-vertex attributes and triangles and the mesh's triangles; set_nodes
  // must follow before a render. Throws Error when the mesh is not the bound one (vertex count) or
  // the coarse surface has 2^24 triangles or more.
  void set_binding(const SurfaceBinding& binding, const Mesh& mesh);
  // The coarse body's deformed nodes, all binding.node_count of them (the surface ones are
  // uploaded, with their normals for the interpolated basis). Throws Error for another count.
  void set_nodes(const std::vector<Eigen::Vector3d>& deformed_nodes);
  // Renders one frame of width x height and reads it back; stats->milliseconds is the draw, from
  // its first call to glFinish (as gl::Renderer's, so set_nodes' upload is not in it).
  Image render(const Camera& camera, int width, int height, const RenderSettings& settings,
               FrameStats* stats = nullptr);
  // What the vertex shader computes for every vertex (position and the carried normal, not
  // normalised), read back in float: one point per vertex drawn into two RGBA32F attachments.
  struct Mapped {
    std::vector<Eigen::Vector3f> positions, normals;
  };
  Mapped mapped_vertices();
  int surface_nodes() const;  // nodes uploaded per frame
  // Bytes of GPU memory the binding (vertex attributes, indices, the coarse triangles) and the
  // nodes hold, as allocated.
  std::size_t gpu_bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace raywarp::gl
