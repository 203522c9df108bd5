// A simulated state's two routes to the screen (docs/simulation.md#speed): the deformation
// texture D baked from the state (the automatic layout a scene's bake picks), and 512² frames of
// the image-space route (D ray cast) against the object-space mappings (the mesh's vertices in
// the box moved by a vertex shader, triangle and interpolated basis). Medians of --runs bakes
// and --frames frames after one warm-up frame each. The simulation is run once, not timed here
// (bench/physics times steps). Usage: raywarp_simulation_bench [--runs N] [--frames N]
// [--size N] [--context auto|egl|osmesa] [SCENE] (default examples/bunny_simulation.json).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "base/error.h"
#include "base/format.h"
#include "gl/context.h"
#include "gl/frame_timing.h"
#include "gl/renderer.h"
#include "gl/surface_mapping_render.h"
#include "library/deformation_bake.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "library/surface_mapping.h"

using namespace raywarp;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  int runs = 3, frames = 10, size = 512;
  std::string context_kind = "auto";
  fs::path scene_file = fs::path(RAYWARP_SOURCE_DIR) / "examples/bunny_simulation.json";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--frames" && i + 1 < argc) {
      frames = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--size" && i + 1 < argc) {
      size = std::clamp(std::atoi(argv[++i]), 16, 4096);
    } else if (a == "--context" && i + 1 < argc) {
      context_kind = argv[++i];
    } else if (a == "--help" || a == "-h" || a.rfind("--", 0) == 0) {
      std::cerr << "usage: raywarp_simulation_bench [--runs N] [--frames N] [--size N] "
                   "[--context auto|egl|osmesa] [SCENE]\n";
      return a == "--help" || a == "-h" ? 0 : 2;
    } else {
      scene_file = a;
    }
  }
  try {
    auto context = gl::create_context(context_kind);
    const Scene scene = load_scene(scene_file.string());
    std::ostringstream log;
    const PreparedScene prepared = prepare_scene(scene, log);
    if (prepared.boxes.size() != 1 || !prepared.boxes[0].report.simulation)
      throw Error(scene_file.string() + ": needs one box with a simulation deformer");
    const BakedBox& box = prepared.boxes[0];
    const SimulationReport& sim = *box.report.simulation;
    const Camera camera = scene.camera ? *scene.camera : Camera{};
    std::printf("%s: %s; %d nodes, %d springs, %ld steps; context %s\n\n",
                scene_file.filename().string().c_str(), box.report.deformer.c_str(), sim.body.nodes,
                sim.body.springs, sim.steps, context->description().c_str());

    // D from the state: the automatic layout, as the bake stage runs it.
    const double voxel = box.report.voxel;
    const Eigen::Vector3d h = box.textures.box.half_extents;
    const auto budget =
        static_cast<std::uint64_t>(scene.boxes[0].deformation_max_mib * double(1 << 20));
    std::vector<double> bake_s;
    AutoDeformation last;
    for (int r = 0; r < runs; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      last = bake_deformation_auto(*box.deformer, h, kAutoErrorVoxels * voxel, budget,
                                   kAutoFloorResolution, false);
      bake_s.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    const Eigen::Vector3i res = last.texture.grid.dims;
    std::printf(
        "| D from the state | texels | MiB | median s (%d runs) |\n| --- | ---: | ---: | ---: |\n"
        "| %dx%dx%d | %ld | %.1f | %.2f |\n\n",
        runs, res.x(), res.y(), res.z(), static_cast<long>(res.prod()),
        res.prod() * 16.0 / 1048576.0, median(bake_s));

    std::printf("| route (%d²) | median ms (%d frames) |\n| --- | ---: |\n", size, frames);
    {
      gl::Renderer renderer;
      renderer.set_mesh(prepared.mesh());
      renderer.set_boxes(prepared.textures());
      std::printf("| image space (D ray cast) | %.1f |\n",
                  frame_median(renderer, camera, size, size, scene.render, frames));
    }
    const BodySurface surface =
        simulation_body_surface(*sim.lattice, *sim.state, box.textures.box, prepared.mesh());
    for (SurfaceBasis basis : {SurfaceBasis::Triangle, SurfaceBasis::Interpolated}) {
      const SurfaceBinding binding = bind_surface(prepared.mesh(), surface.rest, surface.triangles,
                                                  basis, nullptr, &surface.moves);
      gl::SurfaceMappingRenderer renderer;
      renderer.set_binding(binding, prepared.mesh());
      renderer.set_nodes(surface.moved);
      gl::FrameStats stats;
      renderer.render(camera, size, size, scene.render, &stats);  // warm-up
      std::vector<double> ms;
      for (int f = 0; f < frames; ++f) {
        renderer.render(camera, size, size, scene.render, &stats);
        ms.push_back(stats.milliseconds);
      }
      std::printf("| object space (%s basis) | %.1f |\n", basis_name(basis), median(ms));
    }
  } catch (const Error& e) {
    std::cerr << "raywarp_simulation_bench: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
