// The command line's view of the library's bake jobs: bakes every box of a scene and prints the
// report the way `raywarp render` does (mesh, each stage with its size, memory and time, the
// figures measured on the textures, warnings). The command line, the tests and the benchmarks
// share this one path; the baking itself is library/bake.h.
#pragma once
#include <iosfwd>
#include <string>

#include "gl/renderer.h"
#include "library/bake.h"

namespace raywarp {

// Bakes every box in `session`, logging progress (once a bake has run for a second) and then each
// box's report to `log`.
PreparedScene prepare_scene(const Scene& scene, std::ostream& log, BakeSession& session,
                            bool centre_on_lower_faces = false);
// The same in a session of its own over the disk cache `cache` (null: none).
PreparedScene prepare_scene(const Scene& scene, std::ostream& log, BakeCache* cache = nullptr,
                            bool centre_on_lower_faces = false);

// Bakes one job in `session` with progress on `log` (each quarter of a stage, once the bake has
// run for a second), then prints its report, each line prefixed by `tag`.
BakedBox bake_logged(BakeSession& session, const BakeJob& job, std::ostream& log,
                     const std::string& tag);

// One box's report as the log lines `raywarp render` prints, each prefixed by `tag`.
void print_report(std::ostream& log, const std::string& tag, const BakedBox& box,
                  const BakeSession& session);

// Median frame time (ms) of `frames` frames of width x height after one warm-up frame, which
// pays for llvmpipe's compilation of the shader variants at their first draw.
double frame_median(gl::Renderer& renderer, const Camera& camera, int width, int height,
                    const RenderSettings& settings, int frames);

}  // namespace raywarp
