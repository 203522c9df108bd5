// The GL renderer: pass 1 rasterises the mesh with the fragments inside every box discarded;
// pass 2 draws, per box, the bounds of the deformed box and ray casts the deformed part in the
// fragment shader (shaders/raycast.frag.glsl), writing gl_FragDepth so the passes composite
// by a plain depth test. Both passes also write linear eye depth to a float attachment, read
// back as the depth image. Needs a current gl::Context.
#pragma once
#include <memory>
#include <vector>

#include "library/camera.h"
#include "library/image.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "library/textures.h"

namespace raywarp::gl {

struct FrameStats {
  double milliseconds = 0.0;  // both passes, from the first draw to glFinish
  long nonfinite_pixels = 0;  // NaN or Inf in colour or depth, replaced by background
};

class Renderer {
 public:
  static constexpr int kMaxBoxes = 16;
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  void set_mesh(const Mesh& mesh);
  void set_boxes(const std::vector<BoxTextures>& boxes);  // uploads the textures
  // Renders one frame of width x height and reads it back.
  Image render(const Camera& camera, int width, int height, const RenderSettings& settings,
               FrameStats* stats = nullptr);
  // Bytes of GPU texture memory held for the boxes.
  size_t texture_bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace raywarp::gl
