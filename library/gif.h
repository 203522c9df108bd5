// Animated GIF previews of rendered sequences, through giflib (Debian's libgif-dev).
#pragma once
#include <string>
#include <vector>

#include "library/image.h"

namespace raywarp {

// Writes `frames` (all the same size) as a looping GIF with `delay_cs` hundredths of a second per
// frame. One global palette of 256 colours is chosen by giflib's median cut (GifQuantizeBuffer)
// from the frames themselves (every k-th pixel of each, at most 2^22 in all), and every pixel
// takes its nearest palette colour. Written to a temporary file and renamed, so a failure never
// leaves a half-written file; throws Error naming the path.
void write_gif(const std::string& path, const std::vector<Image>& frames, int delay_cs);

}  // namespace raywarp
