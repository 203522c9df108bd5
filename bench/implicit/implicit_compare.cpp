// raywarp_implicit_compare: the depth-map cube against the distance grid (not a test).
//   raywarp_implicit_compare [--frames N] [--size PX] [--resolution N] [--out FILE.md]
//                            [--images DIR] [--context KIND]
// Renders the same deformation scenes with each implicit representation of S_D, at the same
// resolution (texels along the box's longest side): the bunny twist and bend of examples/, the
// dragon twist of examples/study/, and a twisted sphere (convex, which every face of a depth cube
// sees). Per scene and implicit: the implicit's texture memory, its bake time, the frame time
// (median of N frames after a warm-up, both passes, to glFinish) and the error against the exact
// ground truth (the mesh subdivided to a quarter voxel, split at the box, its inside part mapped by
// the deformer's exact forward map, rasterised on the CPU): silhouette IoU and the share of the
// commonly covered pixels whose depth is off by more than 1 % of the deformed mesh's diagonal, as
// tests/render_test.cpp measures them. The scenes' own render settings (threshold sampling).
// --out FILE.md replaces the text between <!-- implicit_compare:begin --> and
// <!-- implicit_compare:end --> of FILE.md (or writes the file when it has none).
// --images DIR writes, per scene, the ground truth and both renders with the pixels that fail
// either measure tinted red (DIR/<scene>_{truth,sdf,depth_cube}.png), and the two renders side
// by side (DIR/<scene>_pair.png: distance grid left, depth cube right).
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
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
#include "tests/mesh_fixtures.h"
#include "verify/reference.h"

using namespace raywarp;
namespace fs = std::filesystem;

namespace {

struct Case {
  std::string name;
  Scene scene;
  Camera camera;
};

struct Row {
  std::string scene, implicit;
  long triangles = 0;
  double mib = 0.0, bake_s = 0.0, frame_ms = 0.0, iou = 0.0, over = 0.0, mean_err = 0.0;
};

// A scene file as JSON with its mesh replaced (an absolute path), loaded through load_scene.
Scene load_with_mesh(const fs::path& scene_file, const fs::path& mesh, const fs::path& folder) {
  nlohmann::json j;
  std::ifstream(scene_file) >> j;
  j["mesh"] = mesh.string();
  if (j.contains("camera") && j["camera"].is_string())
    j["camera"] = (scene_file.parent_path() / j["camera"].get<std::string>()).string();
  const fs::path path = folder / scene_file.filename();
  write_file_atomic(path.string(), j.dump(2));
  return load_scene(path);
}

std::vector<Case> cases(const fs::path& folder) {
  const fs::path root = RAYWARP_SOURCE_DIR;
  std::vector<Case> out;
  for (const char* name : {"bunny_twist", "bunny_bend"}) {
    Scene s = load_scene(root / "examples" / (std::string(name) + ".json"));
    Camera c = *s.camera;
    out.push_back({name, std::move(s), c});
  }
  const fs::path dragon = fs::path(RAYWARP_DATA_DIR) / "dragon_res2.ply";
  if (fs::exists(dragon)) {
    Scene s = load_with_mesh(root / "examples/study/dragon_twist.json", dragon, folder);
    Camera c = *s.camera;
    out.push_back({"dragon_twist", std::move(s), c});
  } else {
    std::cerr << "raywarp_implicit_compare: " << dragon << " is missing (the build unpacks it); "
              << "skipping the dragon\n";
  }
  // A sphere (icosphere, 5120 triangles) twisted by 180 degrees above its lower fifth.
  const Mesh sphere = fixtures::icosphere(1.0, 4);
  write_file_atomic((folder / "sphere.obj").string(), [&](std::ostream& obj) {
    for (Eigen::Index v = 0; v < sphere.V.rows(); ++v)
      obj << "v " << sphere.V(v, 0) << " " << sphere.V(v, 1) << " " << sphere.V(v, 2) << "\n";
    for (Eigen::Index f = 0; f < sphere.F.rows(); ++f)
      obj << "f " << sphere.F(f, 0) + 1 << " " << sphere.F(f, 1) + 1 << " " << sphere.F(f, 2) + 1
          << "\n";
  });
  write_file_atomic((folder / "sphere_twist.json").string(), R"({
    "mesh": "sphere.obj",
    "boxes": [{"min": [-1.1, -0.6, -1.1], "max": [1.1, 1.1, 1.1],
               "deformer": {"type": "twist", "axis": "y", "angle_deg": 180},
               "implicit": {"type": "sdf", "resolution": 128}}],
    "camera": {"eye": [2.4, 2.0, 4.2], "target": [0, 0.1, 0], "fov_y_deg": 36, "near": 1,
               "far": 20},
    "render": {"width": 512, "height": 512}})");
  Scene s = load_scene(folder / "sphere_twist.json");
  Camera c = *s.camera;
  out.push_back({"sphere_twist", std::move(s), c});
  return out;
}

// `image` with the pixels where it and `truth` disagree (coverage, or depth beyond `threshold`)
// tinted red.
Image mark_errors(const Image& image, const Image& truth, double threshold) {
  Image out = image;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const bool a = image.covered(x, y), b = truth.covered(x, y);
      const bool wrong =
          a != b || (a && std::abs(image.depth_at(x, y) - truth.depth_at(x, y)) > threshold);
      if (!wrong) continue;
      uint8_t* px = &out.rgba[4 * (static_cast<size_t>(y) * image.width + x)];
      px[0] = 230;
      px[1] = px[1] / 3;
      px[2] = px[2] / 3;
    }
  return out;
}

// a and b (of one size) side by side.
Image side_by_side(const Image& a, const Image& b) {
  Image out(2 * a.width, a.height);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < 2 * a.width; ++x) {
      const Image& from = x < a.width ? a : b;
      const int fx = x % a.width;
      const size_t to = static_cast<size_t>(y) * out.width + x,
                   src = static_cast<size_t>(y) * from.width + fx;
      out.depth[to] = from.depth[src];
      for (int c = 0; c < 4; ++c) out.rgba[4 * to + c] = from.rgba[4 * src + c];
    }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 5, size = 512, resolution = 128;
  std::string out, images, context_kind = "osmesa";
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
      } else if (a == "--resolution") {
        resolution = std::stoi(value("texels along the box's longest side"));
      } else if (a == "--out") {
        out = value("a Markdown file");
      } else if (a == "--images") {
        images = value("a folder");
      } else if (a == "--context") {
        context_kind = value("auto, egl or osmesa");
      } else {
        std::cerr << "usage: raywarp_implicit_compare [--frames N] [--size PX] [--resolution N] "
                     "[--out FILE.md] [--images DIR] [--context auto|egl|osmesa]\n";
        return a == "--help" || a == "-h" ? 0 : 2;
      }
    } catch (const std::exception& e) {
      std::cerr << "raywarp_implicit_compare: " << e.what() << "\n";
      return 2;
    }
  }
  if (frames < 1 || size < 16 || size > 8192 || resolution < 8 || resolution > 1024) {
    std::cerr << "raywarp_implicit_compare: frames >= 1, size in [16, 8192], resolution in "
                 "[8, 1024]\n";
    return 2;
  }
  const fs::path folder =
      fs::temp_directory_path() / ("raywarp_implicit_compare_" + std::to_string(::getpid()));
  std::vector<Row> rows;
  std::string context_description;
  try {
    fs::create_directories(folder);
    if (!images.empty()) fs::create_directories(images);
    const auto context = gl::create_context(context_kind);
    context_description = context->description();
    for (Case& c : cases(folder)) {
      c.scene.boxes[0].implicit.resolution = resolution;
      Image truth, marked[2];
      double diagonal = 0.0;
      for (const char* implicit : {"sdf", "depth_cube"}) {
        c.scene.boxes[0].implicit.type = implicit;
        std::ostringstream log;
        const PreparedScene prepared = prepare_scene(c.scene, log);
        const BakedBox& box = prepared.boxes[0];
        const BoxTextures& t = box.textures;
        if (truth.width == 0) {  // the same for both: the mesh and the exact forward map
          auto F = [&](const Eigen::Vector3d& p) { return box.deformer->forward(p); };
          const Mesh truth_mesh =
              ground_truth_mesh(prepared.mesh(), t.box, F, 0.25 * implicit_spacing(t));
          truth = rasterize(truth_mesh, c.camera, size, size, c.scene.render);
          diagonal = mesh_bounds(truth_mesh).diagonal().norm();
          if (!images.empty()) write_png(images + "/" + c.name + "_truth.png", truth);
        }
        gl::Renderer renderer;
        renderer.set_mesh(prepared.mesh());
        renderer.set_boxes(prepared.textures());
        const double ms = frame_median(renderer, c.camera, size, size, c.scene.render, frames);
        const Image image = renderer.render(c.camera, size, size, c.scene.render);
        const ImageComparison cmp = compare_images(image, truth, 0.01 * diagonal);
        if (!images.empty()) {
          Image& m = marked[t.uses_depth_cube ? 1 : 0];
          m = mark_errors(image, truth, 0.01 * diagonal);
          write_png(images + "/" + c.name + "_" + implicit + ".png", m);
          if (t.uses_depth_cube)
            write_png(images + "/" + c.name + "_pair.png", side_by_side(marked[0], m));
        }
        Row r;
        r.scene = c.name;
        r.implicit = implicit;
        r.triangles = prepared.stats().faces;
        r.mib = (t.uses_depth_cube ? double(t.depth_cube.texture_bytes())
                                   : double(t.sdf.grid.size()) * 4.0) /
                (1 << 20);
        r.bake_s = t.uses_depth_cube ? t.depth_cube.bake_seconds : t.sdf.bake_seconds;
        r.frame_ms = ms;
        r.iou = cmp.iou;
        r.over = cmp.fraction_over;
        r.mean_err = cmp.mean_depth_error / diagonal;
        rows.push_back(r);
        std::fprintf(
            stderr, "%-13s %-10s %7.3f MiB  bake %6.3f s  frame %7.1f ms  IoU %.4f  over %.2f %%\n",
            r.scene.c_str(), implicit, r.mib, r.bake_s, r.frame_ms, r.iou, 100 * r.over);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "raywarp_implicit_compare: " << e.what() << "\n";
    fs::remove_all(folder);
    return 1;
  }
  fs::remove_all(folder);

  std::ostringstream table;
  table
      << "Measured by `build/raywarp_implicit_compare --frames " << frames << " --size " << size
      << " --resolution " << resolution << "` on " << context_description << ".\n"
      << "Implicit resolution " << resolution
      << " texels along the box's longest side for both; frame: median of " << frames
      << " frames at " << size << "x" << size
      << " after a warm-up (both passes, to glFinish), the scenes' threshold sampling; error "
         "against the exact ground truth: silhouette IoU, and the share of commonly covered "
         "pixels whose depth is off by more than 1 % of the deformed mesh's diagonal (the "
         "project's thresholds: IoU >= 0.98, <= 2 %); mean depth error in % of the diagonal.\n\n"
      << "| scene | triangles | implicit | memory MiB | bake s | frame ms | IoU | depth off > 1 % "
         "| mean depth err % |\n"
      << "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const Row& r : rows) {
    char line[512];
    std::snprintf(
        line, sizeof line, "| %s | %ld | %s | %.3g | %.3f | %.1f | %.4f | %.2f %% | %.3f |\n",
        r.scene.c_str(), r.triangles, r.implicit == "sdf" ? "distance grid" : "depth cube", r.mib,
        r.bake_s, r.frame_ms, r.iou, 100 * r.over, 100 * r.mean_err);
    table << line;
  }
  std::cout << table.str();
  if (!out.empty()) {
    try {
      bench::write_marked_block(out, "implicit_compare", table.str(),
                                "Depth cube against distance grid");
    } catch (const std::exception& e) {
      std::cerr << "raywarp_implicit_compare: " << e.what() << "\n";
      return 2;
    }
  }
  return 0;
}
