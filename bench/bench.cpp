// raywarp_bench: bake and frame times, medians over repeated runs (not a test).
//   raywarp_bench [--runs N] [--frames N] [--size PX] [--out FILE.md]
// For each mesh (the shipped bunny, and the Stanford dragon, 202K triangles) it places a twist
// box over the middle 60 % of the mesh's height and a bend box around the whole mesh, and times
// the distance-grid bake, the deformation bake, and GL frames at SIZE² (OSMesa unless another
// context is current), each the median of N runs.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "deformers/bend.h"
#include "deformers/twist.h"
#include "library/gl/context.h"
#include "library/gl/renderer.h"
#include "library/implicit.h"
#include "library/mesh.h"

using namespace raywarp;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

template <class F>
double time_ms(F&& f) {
  auto start = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

struct Row {
  std::string mesh, deformer;
  long triangles;
  int sdf_res, def_res;
  double sdf_ms, def_ms, frame_ms;
  double sdf_mib, def_mib;
};

}  // namespace

int main(int argc, char** argv) {
  int runs = 5, frames = 7, size = 512;
  std::string out;
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
    else {
      std::cerr << "usage: raywarp_bench [--runs N] [--frames N] [--size PX] [--out FILE.md]\n";
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  auto context = gl::create_osmesa_context();
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
      const int def_res = 96;
      BoxTextures tex;
      tex.box = box;
      std::vector<double> sdf_t, def_t, frame_t;
      for (int r = 0; r < runs; ++r) {
        sdf_t.push_back(time_ms([&] { tex.sdf = bake_distance_grid(mesh, box, spec); }));
        def_t.push_back(time_ms(
            [&] { tex.deformation = bake_deformation(*deformer, box.half_extents, def_res); }));
      }
      gl::Renderer renderer;
      renderer.set_mesh(mesh);
      renderer.set_boxes({tex});
      Camera cam;
      Eigen::Vector3d c = 0.5 * (lo + hi);
      double radius = 0.5 * ext.norm() * (kind == "bend" ? 1.3 : 1.0);
      cam.target = c;
      cam.eye = c + Eigen::Vector3d(0.25, 0.2, 1.0).normalized() * radius * 3.2;
      cam.fov_y_deg = 40;
      cam.near_plane = radius * 0.5;
      cam.far_plane = radius * 10;
      RenderSettings settings;
      gl::FrameStats fs;
      renderer.render(cam, size, size, settings, &fs);  // warm-up: shader compile, first upload
      for (int f = 0; f < frames; ++f) {
        renderer.render(cam, size, size, settings, &fs);
        frame_t.push_back(fs.milliseconds);
      }
      rows.push_back({name, deformer->describe(), static_cast<long>(stats.faces), spec.resolution,
                      def_res, median(sdf_t), median(def_t), median(frame_t),
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
        << " (both passes, to glFinish).\n\n"
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
  std::cout << table.str();
  if (!out.empty()) {
    std::ofstream f(out);
    f << "# Bake and frame times\n\n" << table.str();
    if (!f) {
      std::cerr << "raywarp_bench: cannot write " << out << "\n";
      return 2;
    }
  }
  return 0;
}
