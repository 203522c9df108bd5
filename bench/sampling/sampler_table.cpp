// raywarp_sampler_table: what the default sampler misses, and what it costs, against the other
// two on the continuous scenes of examples/zoo and the twists of examples/ (not a test).
//   raywarp_sampler_table [--frames N] [--size PX] [--only TEXT] [--out FILE.md] [--context KIND]
// Per scene, in one run: the scene baked and drawn three ways at SIZE x SIZE, its own settings
// but for the sampling: the default (`threshold`), `linear` at 0.5 voxel (the paper's step) and
// `bounded` (sphere tracing with Lipschitz bounds, which never steps over a surface). For each,
// the frame time (median of N frames after a warm-up, both passes, to glFinish); of the pixels
// `bounded` covers, those the default and linear miss; of the pixels both `bounded` and the exact
// ground truth cover (the mesh subdivided to a quarter voxel, split at the box, mapped by the
// exact forward map, rasterised), those the default misses: the misses that are not `bounded`'s
// hit rule (a sample within its epsilon of the surface counts as a hit there). Also the frame of
// the same mesh with no box (the raster pass alone): the part of every frame no sampler changes.
// --only TEXT keeps the scenes whose name contains TEXT.
// --out FILE.md replaces the text between <!-- sampler_table:begin --> and
// <!-- sampler_table:end --> of FILE.md (or writes the file when it has none).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "base/error.h"
#include "bench/marked_block.h"
#include "gl/context.h"
#include "gl/frame_timing.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

using namespace raywarp;
namespace fs = std::filesystem;

namespace {

struct Row {
  std::string scene;
  long bounded = 0, truth_and_bounded = 0;
  long missed[2] = {0, 0};   // of bounded's: default, linear
  long missed_real = 0;      // of bounded's and the truth's: default
  double ms[3] = {0, 0, 0};  // default, linear, bounded
  double raster_ms = 0;      // the mesh alone, no box
};

std::vector<fs::path> scenes(const std::string& only) {
  const fs::path root = RAYWARP_SOURCE_DIR;
  std::vector<fs::path> out = {root / "examples/bunny_twist.json",
                               root / "examples/bunny_head_twist.json"};
  std::vector<fs::path> zoo;
  for (const auto& e : fs::directory_iterator(root / "examples/zoo")) {
    const std::string stem = e.path().stem().string();
    if (e.path().extension() == ".json" && (stem.ends_with("_twist") || stem.ends_with("_bend")))
      zoo.push_back(e.path());
  }
  std::sort(zoo.begin(), zoo.end());
  out.insert(out.end(), zoo.begin(), zoo.end());
  std::erase_if(
      out, [&](const fs::path& f) { return f.stem().string().find(only) == std::string::npos; });
  return out;
}

std::string percent(long part, long whole) {
  char s[64];
  std::snprintf(s, sizeof s, "%ld (%.3f %%)", part, whole ? 100.0 * part / whole : 0.0);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 5, size = 512;
  std::string out, only, context_kind = "osmesa";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* what) -> std::string {
      if (i + 1 >= argc) throw Error(a + ": give " + what);
      return argv[++i];
    };
    try {
      if (a == "--frames") {
        frames = std::stoi(value("a number of frames"));
      } else if (a == "--size") {
        size = std::stoi(value("the image side in pixels"));
      } else if (a == "--only") {
        only = value("text in the scenes' names");
      } else if (a == "--out") {
        out = value("a Markdown file");
      } else if (a == "--context") {
        context_kind = value("auto, egl or osmesa");
      } else {
        std::cerr << "usage: raywarp_sampler_table [--frames N] [--size PX] [--only TEXT] "
                     "[--out FILE.md] [--context auto|egl|osmesa]\n";
        return a == "--help" || a == "-h" ? 0 : 2;
      }
    } catch (const std::exception& e) {
      std::cerr << "raywarp_sampler_table: " << e.what() << "\n";
      return 2;
    }
  }
  if (frames < 1 || size < 16 || size > 8192) {
    std::cerr << "raywarp_sampler_table: frames >= 1, size in [16, 8192]\n";
    return 2;
  }
  std::vector<Row> rows;
  std::string context_description;
  try {
    const auto context = gl::create_context(context_kind);
    context_description = context->description();
    for (const fs::path& file : scenes(only)) {
      Row r;
      r.scene = file.stem().string();
      Image images[3], truth;
      for (int k = 0; k < 3; ++k) {
        Scene scene = load_scene(file);
        const Camera camera = *scene.camera;
        if (k == 1) {
          scene.render.sampling = Sampling::Linear;
          scene.render.step_voxels = kFineStepVoxels;
          scene.render.max_steps *= 16;
        } else if (k == 2) {
          scene.render.sampling = Sampling::Bounded;
        }
        std::ostringstream log;
        const PreparedScene prepared = prepare_scene(scene, log);
        if (k == 0) {
          const BakedBox& box = prepared.boxes[0];
          auto F = [&](const Eigen::Vector3d& p) { return box.deformer->forward(p); };
          const Mesh truth_mesh = ground_truth_mesh(prepared.mesh(), box.textures.box, F,
                                                    0.25 * box.textures.sdf.grid.voxel());
          truth = rasterize(truth_mesh, camera, size, size, scene.render);
        }
        gl::Renderer renderer;
        renderer.set_mesh(prepared.mesh());
        renderer.set_boxes(prepared.textures());
        r.ms[k] = frame_median(renderer, camera, size, size, scene.render, frames);
        images[k] = renderer.render(camera, size, size, scene.render);
        if (k == 0) {
          gl::Renderer mesh_only;
          mesh_only.set_mesh(prepared.mesh());
          r.raster_ms = frame_median(mesh_only, camera, size, size, scene.render, frames);
        }
      }
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          if (!images[2].covered(x, y)) continue;
          ++r.bounded;
          r.missed[0] += !images[0].covered(x, y);
          r.missed[1] += !images[1].covered(x, y);
          if (!truth.covered(x, y)) continue;
          ++r.truth_and_bounded;
          r.missed_real += !images[0].covered(x, y);
        }
      rows.push_back(r);
      std::fprintf(stderr,
                   "%-22s default misses %s of bounded's, %s of bounded's and the truth's; "
                   "frame ms %.1f / %.1f / %.1f (default / linear / bounded), no box %.1f\n",
                   r.scene.c_str(), percent(r.missed[0], r.bounded).c_str(),
                   percent(r.missed_real, r.truth_and_bounded).c_str(), r.ms[0], r.ms[1], r.ms[2],
                   r.raster_ms);
    }
  } catch (const std::exception& e) {
    std::cerr << "raywarp_sampler_table: " << e.what() << "\n";
    return 1;
  }
  std::ostringstream table;
  table << "Measured by `build/raywarp_sampler_table --frames " << frames << " --size " << size
        << "` on " << context_description << ". Frame: median of " << frames << " frames at "
        << size << "x" << size
        << " after a warm-up (both passes, to glFinish), each scene's own settings but for the "
           "sampling; every ratio is of frame times measured in the same run.\n\n"
        << "| scene | `bounded` covers | default misses of those | `linear` 0.5 misses of those "
           "| default misses of those the truth also covers | default ms | `linear` ms | "
           "`bounded` ms | no box ms | default / `linear` | `bounded` / `linear` |\n"
        << "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const Row& r : rows) {
    char line[768];
    std::snprintf(line, sizeof line,
                  "| `%s` | %ld | %s | %s | %s | %.1f | %.1f | %.1f | %.1f | %.2f | %.2f |\n",
                  r.scene.c_str(), r.bounded, percent(r.missed[0], r.bounded).c_str(),
                  percent(r.missed[1], r.bounded).c_str(),
                  percent(r.missed_real, r.truth_and_bounded).c_str(), r.ms[0], r.ms[1], r.ms[2],
                  r.raster_ms, r.ms[0] / r.ms[1], r.ms[2] / r.ms[1]);
    table << line;
  }
  std::cout << table.str();
  if (!out.empty()) bench::write_marked_block(out, "sampler_table", table.str(), "Samplers");
  return 0;
}
