// A scene prepared for rendering: every box baked through the library's bake jobs (library/bake.h),
// with progress and each box's report written to a log the caller gives, as `raywarp render`
// prints it (mesh, each stage with its size, memory and time, the figures measured on the
// textures, warnings). The command line, the editor's tests and the benchmarks share this one
// path; the library prints nothing on its own.
#pragma once
#include <iosfwd>
#include <string>

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

}  // namespace raywarp
