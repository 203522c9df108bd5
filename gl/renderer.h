// The GL renderer: pass 1 rasterises the mesh with the fragments inside every box discarded;
// pass 2 draws, per box, the bounds of the deformed box and ray casts the deformed part in the
// fragment shader (shaders/raycast.frag.glsl), writing gl_FragDepth so the passes composite
// by a plain depth test. Both passes also write linear eye depth to a float attachment, read
// back as the depth image. Needs a current gl::Context.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "gl/raycast_tables.h"
#include "library/camera.h"
#include "library/image.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "library/textures.h"

namespace raywarp::gl {

class ShaderFiles;

struct FrameStats {
  double milliseconds = 0.0;  // both passes, from the first draw to glFinish
  long nonfinite_pixels = 0;  // NaN or Inf in colour or depth, replaced by background
};

// Reads the bound framebuffer's colour (attachment 0, RGBA8) and linear depth (attachment 1, R32F)
// of width x height pixels into an Image, rows flipped (GL's row 0 is the bottom, raywarp's the
// top: docs/conventions.md#image-rows); a NaN or -inf depth becomes +inf with the `clear` colour
// (its channels in [0, 1] as stored), and `nonfinite` (if given) counts those pixels. The
// renderers' common read-back.
Image read_back_image(int width, int height, const float clear[4], long* nonfinite = nullptr);

// Whether a box is ray cast by the `bounded` tracer under `settings`: traces_bounded decides it
// (throws Error when it does and the box has no step bounds, or reads D through a texture map).
bool uses_bounded(const BoxTextures& b, const RenderSettings& settings);
// The features of a box's ray-cast variant (gl/raycast_tables.h): its sampling, cut mode, depth
// cube, D = 0, texture map, skipping.
Variant raycast_variant(const BoxTextures& b, const RenderSettings& settings);
// The #defines that select a box's ray-cast variant: raycast_variant(b, settings).defines().
std::string raycast_defines(const BoxTextures& b, const RenderSettings& settings);
// The fragment shader text the renderer compiles for a box: shaders/raycast.frag.glsl with its
// includes, and only the branches of the box's variant (assemble_shader resolves the RAYWARP_*
// conditionals and drops comments).
std::string raycast_fragment_source(const BoxTextures& b, const RenderSettings& settings);

class Renderer {
 public:
  static constexpr int kMaxBoxes = 16;
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  void set_mesh(const Mesh& mesh);
  void set_boxes(const std::vector<BoxTextures>& boxes);         // uploads the textures
  void set_boxes(const std::vector<const BoxTextures*>& boxes);  // the same, with no copy
  // Moves box `box`'s deformation texture by the map M of eq. 2 (BoxTextures::texture_map), with
  // the region rays are cast over and the bound of |I + J_D| that go with it; no texel is
  // uploaded again.
  void set_texture_map(size_t box, const Eigen::Matrix4d& texture_map,
                       const Eigen::AlignedBox3d& region, double lipschitz);
  // Whether pass 2 ray casts the boxes (default true). false: the frame holds the mesh outside
  // the boxes only, for a front end that shows the boxes another way (the tetrahedral route) and
  // composites by depth (composite_nearest).
  void set_ray_cast(bool on);
  // Renders one frame of width x height and reads it back.
  Image render(const Camera& camera, int width, int height, const RenderSettings& settings,
               FrameStats* stats = nullptr);
  // Compiles the shaders of `files` (a table of the files of shaders/, e.g. read_shader_folder)
  // in place of the current ones, at once: the mesh pass and every ray-cast variant compiled so
  // far; variants first needed later compile from them too. Throws Error with the driver's log
  // (file and line) when one does not compile or link; the current shaders then stay.
  void set_shader_files(const ShaderFiles& files);
  // Bytes of GPU texture memory held for the boxes.
  size_t texture_bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace raywarp::gl
