#include "gl/frame_timing.h"

#include <vector>

#include "base/format.h"

namespace raywarp {

double frame_median(gl::Renderer& renderer, const Camera& camera, int width, int height,
                    const RenderSettings& settings, int frames) {
  gl::FrameStats stats;
  renderer.render(camera, width, height, settings, &stats);
  std::vector<double> ms;
  for (int f = 0; f < frames; ++f) {
    renderer.render(camera, width, height, settings, &stats);
    ms.push_back(stats.milliseconds);
  }
  return median(ms);
}

}  // namespace raywarp
