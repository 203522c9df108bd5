// Frame timing for the benchmarks and `raywarp render --time`: the median of several frames.
#pragma once
#include "gl/renderer.h"

namespace raywarp {

// Median frame time (ms) of `frames` frames of width x height after one warm-up frame, which
// pays for llvmpipe's compilation of the shader variants at their first draw.
double frame_median(gl::Renderer& renderer, const Camera& camera, int width, int height,
                    const RenderSettings& settings, int frames);

}  // namespace raywarp
