// raywarp_bench: bake and frame times, medians over repeated runs (not a test).
//   raywarp_bench [--runs N] [--frames N] [--size PX] [--out FILE.md] [--context KIND]
// For each mesh (the shipped bunny, and the Stanford dragon, 202K triangles):
//  1. bakes: a twist box over the middle 60 % of the mesh's height and a bend box around the
//     whole mesh; times the distance-grid bake, the deformation bake, and GL frames at SIZE²
//     (OSMesa), each the median of N runs;
//  2. cuts, in the shape of Correa & Silver's Table 1: frame times of a continuous deformation
//     (twist), a solid box cut (a quarter wedge) and a solid incision in the same box over the
//     upper 55 % of the mesh, each without and with empty-space skipping.
// --out FILE.md replaces the text between the markers <!-- bench:begin --> and
// <!-- bench:end --> of FILE.md (or writes the file when it has none), keeping the rest.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "base/atomic_file.h"
#include "base/error.h"
#include "base/format.h"
#include "bench/marked_block.h"
#include "deformers/bend.h"
#include "deformers/twist.h"
#include "gl/context.h"
#include "gl/frame_timing.h"
#include "gl/renderer.h"
#include "library/deformation_bake.h"
#include "library/implicit.h"
#include "library/mesh.h"
#include "library/prepare.h"

using namespace raywarp;

namespace {

template <class F>
double time_ms(F&& f) {
  auto start = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// The paper's linear search at half a voxel: these tables compare bakes, meshes and cuts at one
// fixed sampling (`raywarp study` compares the sampling methods).
RenderSettings paper_linear() {
  RenderSettings s;
  s.sampling = Sampling::Linear;
  s.step_voxels = kFineStepVoxels;
  return s;
}

Camera framing_camera(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double widen) {
  Camera cam;
  Eigen::Vector3d c = 0.5 * (lo + hi);
  double radius = 0.5 * (hi - lo).norm() * widen;
  cam.target = c;
  cam.eye = c + Eigen::Vector3d(0.25, 0.2, 1.0).normalized() * radius * 3.2;
  cam.fov_y_deg = 40;
  cam.near_plane = radius * 0.5;
  cam.far_plane = radius * 10;
  return cam;
}

struct CutRow {
  std::string mesh;
  long triangles;
  double box_screen;  // fraction of the image the box's ray-cast region covers
  double ms[3][2];    // [twist, box cut, incision][no skipping, skipping]
};

// Fraction of the pixels whose ray meets the box's ray-cast region.
double screen_fraction(const Camera& cam, int size, const BoxTextures& b) {
  const Eigen::AlignedBox3d region = ray_cast_region(b);
  long n = 0;
  for (int y = 0; y < size; y += 4)
    for (int x = 0; x < size; x += 4) {
      Ray r = cam.pixel_ray(x, y, size, size);
      Eigen::Vector3d o = b.box.to_local(r.origin), d = b.box.direction_to_local(r.direction);
      double t0 = 0, t1 = 1e300;
      bool hit = true;
      for (int a = 0; a < 3 && hit; ++a) {
        double ta = (region.min()[a] - o[a]) / d[a], tb = (region.max()[a] - o[a]) / d[a];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
        hit = t0 <= t1;
      }
      n += hit;
    }
  return n / double(((size + 3) / 4) * ((size + 3) / 4));
}

CutRow cut_row(const std::string& name, const std::string& path, int frames, int size) {
  Mesh mesh = load_mesh(path);
  MeshStats stats = mesh_stats(mesh);
  const Eigen::Vector3d lo = stats.bounds.min(), hi = stats.bounds.max(), ext = hi - lo;
  Scene scene;
  scene.mesh = path;
  BoxSpec spec;
  const Eigen::Vector3d bmin(lo.x() - 0.02 * ext.x(), lo.y() + 0.45 * ext.y(),
                             lo.z() - 0.02 * ext.z());
  const Eigen::Vector3d bmax(hi.x() + 0.02 * ext.x(), hi.y() + 0.02 * ext.y(),
                             hi.z() + 0.02 * ext.z());
  spec.box.centre = 0.5 * (bmin + bmax);
  spec.box.half_extents = 0.5 * (bmax - bmin);
  const Eigen::Vector3d& h = spec.box.half_extents;
  CutRow row{name, static_cast<long>(stats.faces), 0.0, {}};
  const Camera cam = framing_camera(lo, hi, 1.0);
  for (int kind = 0; kind < 3; ++kind) {
    DeformerSpec d;
    if (kind == 0) {
      d.type = "twist";
      d.axis = 1;
      d.angle_deg = 360;
    } else if (kind == 1) {
      d.type = "box_cut";
      d.wedge_axis = 1;
      d.wedge_angle_deg = 90;  // the quarter facing the camera
    } else {
      d.type = "incision";
      d.axis = 0;
      d.from_axis = 2;
      d.from_side = 1;
      d.depth = 1.2 * h.z();
      d.opening = 0.3 * h.x();
    }
    spec.deformer = d;
    spec.cut_mode = CutMode::Solid;
    scene.boxes = {spec};
    std::ostringstream log;
    PreparedScene prepared = prepare_scene(scene, log);
    gl::Renderer renderer;
    renderer.set_mesh(prepared.mesh());
    renderer.set_boxes(prepared.textures());
    if (kind == 1) row.box_screen = screen_fraction(cam, size, prepared.boxes[0].textures);
    for (int skip = 0; skip < 2; ++skip) {
      RenderSettings settings = paper_linear();
      settings.skipping = skip == 1;
      row.ms[kind][skip] = frame_median(renderer, cam, size, size, settings, frames);
    }
    std::fprintf(stderr, "  %-28s frame %.1f ms, skipping %.1f ms\n",
                 prepared.boxes[0].deformer->describe().c_str(), row.ms[kind][0], row.ms[kind][1]);
  }
  return row;
}

struct Row {
  std::string mesh, deformer;
  long triangles;
  int sdf_res, def_res;
  double sdf_ms, def_ms, frame_ms;
  double sdf_mib, def_mib;
};

}  // namespace

int run(int argc, char** argv) {
  int runs = 5, frames = 7, size = 512;
  std::string out, context_kind = "osmesa";
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "raywarp_bench: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--runs")
      runs = std::max(1, std::stoi(next()));
    else if (a == "--frames")
      frames = std::max(1, std::stoi(next()));
    else if (a == "--size")
      size = std::clamp(std::stoi(next()), 16, 4096);
    else if (a == "--out")
      out = next();
    else if (a == "--context")
      context_kind = next();
    else {
      std::cerr << "usage: raywarp_bench [--runs N] [--frames N] [--size PX] [--out FILE.md] "
                   "[--context auto|egl|osmesa]\n";
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  std::unique_ptr<gl::Context> context;
  try {
    context = gl::create_context(context_kind);
  } catch (const std::exception& e) {
    std::cerr << "raywarp_bench: " << e.what() << "\n";
    return 2;
  }
  std::vector<std::pair<std::string, std::string>> meshes = {
      {"bunny", std::string(RAYWARP_SOURCE_DIR) + "/examples/meshes/bunny.ply"},
      {"dragon", std::string(RAYWARP_DATA_DIR) + "/dragon_res2.ply"}};
  std::vector<Row> rows;
  for (const auto& [name, path] : meshes) {
    Mesh mesh = load_mesh(path);
    MeshStats stats = mesh_stats(mesh);
    std::cerr << name << ": " << describe(stats) << "\n";
    Eigen::Vector3d lo = stats.bounds.min(), hi = stats.bounds.max(), ext = hi - lo;
    for (const std::string kind : {"twist", "bend"}) {
      Box box;
      if (kind == "twist") {
        Eigen::Vector3d bmin(lo.x() - 0.02 * ext.x(), lo.y() + 0.2 * ext.y(),
                             lo.z() - 0.02 * ext.z());
        Eigen::Vector3d bmax(hi.x() + 0.02 * ext.x(), lo.y() + 0.8 * ext.y(),
                             hi.z() + 0.02 * ext.z());
        box.centre = 0.5 * (bmin + bmax);
        box.half_extents = 0.5 * (bmax - bmin);
      } else {
        box.centre = 0.5 * (lo + hi);
        box.half_extents = 0.51 * ext;
      }
      auto deformer = kind == "twist" ? make_twist(box.half_extents, Axis::Y, 360.0)
                                      : make_bend(box.half_extents, Axis::Z, 90.0);
      ImplicitSpec spec;
      spec.resolution = 128;  // the tables compare at one fixed grid, not the automatic one
      const int def_res = 96;
      BoxTextures tex;
      tex.box = box;
      std::vector<double> sdf_t, def_t;
      for (int r = 0; r < runs; ++r) {
        sdf_t.push_back(time_ms([&] { tex.sdf = bake_distance_grid(mesh, box, spec); }));
        def_t.push_back(time_ms(
            [&] { tex.deformation = bake_deformation(*deformer, box.half_extents, def_res); }));
      }
      tex.lipschitz = displacement_lipschitz(*deformer, tex.deformation);
      gl::Renderer renderer;
      renderer.set_mesh(mesh);
      renderer.set_boxes({tex});
      const Camera cam = framing_camera(lo, hi, kind == "bend" ? 1.3 : 1.0);
      const double frame_ms = frame_median(renderer, cam, size, size, paper_linear(), frames);
      rows.push_back({name, deformer->describe(), static_cast<long>(stats.faces), spec.resolution,
                      def_res, median(sdf_t), median(def_t), frame_ms,
                      tex.sdf.grid.size() * 4.0 / (1 << 20),
                      tex.deformation.grid.size() * 16.0 / (1 << 20)});
      const Row& r = rows.back();
      std::fprintf(stderr, "  %-22s sdf %.0f ms  D %.0f ms  frame %.1f ms\n", r.deformer.c_str(),
                   r.sdf_ms, r.def_ms, r.frame_ms);
    }
  }
  std::ostringstream table;
  table << "Measured by `build/raywarp_bench --runs " << runs << " --frames " << frames
        << " --size " << size << "` on " << context->description() << ".\n"
        << "Medians: distance grid bake and deformation bake over " << runs
        << " runs, frame time over " << frames << " frames at " << size << "x" << size
        << " (both passes, to glFinish), all with linear sampling at 0.5 voxel (the paper's; "
           "`raywarp study` compares the sampling methods, docs/study/report.md).\n\n"
        << "| mesh | triangles | deformer | SDF res | SDF bake ms | SDF MiB | D res | D bake ms | "
           "D MiB | frame ms |\n"
        << "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  char line[512];
  for (const auto& r : rows) {
    std::snprintf(line, sizeof line,
                  "| %s | %ld | %s | %d | %.0f | %.1f | %d | %.0f | %.1f | %.1f |\n",
                  r.mesh.c_str(), r.triangles, r.deformer.c_str(), r.sdf_res, r.sdf_ms, r.sdf_mib,
                  r.def_res, r.def_ms, r.def_mib, r.frame_ms);
    table << line;
  }
  std::vector<CutRow> cut_rows;
  for (const auto& [name, path] : meshes) {
    std::cerr << name << ": cuts\n";
    cut_rows.push_back(cut_row(name, path, frames, size));
  }
  table << "\n### Cuts and empty-space skipping (Correa & Silver's Table 1)\n\n"
        << "Frame ms at " << size << "x" << size << ", medians of " << frames
        << " frames, one view; the box spans the upper 55 % of the mesh and covers the "
           "stated share of the image. Continuous: twist 360\u00b0 about y. Cut: solid box cut "
           "of the quarter wedge facing the camera. Incision: solid, normal x, from +z. "
           "ESK: empty-space skipping (`render.skipping`).\n\n"
        << "| mesh | triangles | box on screen | continuous | continuous ESK | cut (no ESK) | "
           "cut (ESK) | cut speed-up | incision (no ESK) | incision (ESK) | incision speed-up "
           "|\n"
        << "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const auto& r : cut_rows) {
    std::snprintf(line, sizeof line,
                  "| %s | %ld | %.0f %% | %.1f | %.1f | %.1f | %.1f | %.2fx | %.1f | %.1f | "
                  "%.2fx |\n",
                  r.mesh.c_str(), r.triangles, 100 * r.box_screen, r.ms[0][0], r.ms[0][1],
                  r.ms[1][0], r.ms[1][1], r.ms[1][0] / r.ms[1][1], r.ms[2][0], r.ms[2][1],
                  r.ms[2][0] / r.ms[2][1]);
    table << line;
  }
  std::cout << table.str();
  if (!out.empty()) {
    try {
      bench::write_marked_block(out, "bench", table.str(), "Bake and frame times");
    } catch (const Error& e) {
      std::cerr << "raywarp_bench: " << e.what() << "\n";
      return 2;
    }
  }
  return 0;
}

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "raywarp_bench: " << e.what() << "\n";
    return 1;
  }
}
