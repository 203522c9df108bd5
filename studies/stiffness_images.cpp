#include "studies/stiffness_images.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <ostream>
#include <sstream>

#include "base/atomic_file.h"
#include "base/error.h"
#include "base/format.h"
#include "gl/frame_timing.h"
#include "gl/renderer.h"
#include "gl/surface_mapping_render.h"
#include "gl/tet_scene.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "library/surface_mapping.h"
#include "library/tet_body.h"
#include "studies/chart.h"
#include "verify/ground_truth.h"

namespace fs = std::filesystem;

namespace raywarp {

const char* const kStiffnessImagesCsvHeader =
    "ks,route,nodes,steps,sim_seconds,max_node_displacement,folded_percent,iou,over_1pct_percent,"
    "mean_depth_error,frame_ms,vertex_error_max,vertex_error_mean,d_texels,d_mib,d_seconds,"
    "d_error_voxels,gpu_mib,tets,tet_refine";

namespace {

using Clock = std::chrono::steady_clock;

std::string num(double v) { return std::isnan(v) ? "" : fmt("%.6g", v); }

struct Route {
  std::string name;  // "image space", "object space (triangle)", ...
  ImageComparison c;
  double frame_ms = NAN;
  double vertex_max = NAN, vertex_mean = NAN;  // object space: |mapped - F(vertex)|
  double gpu_mib = NAN;                        // what the route holds on the GPU
  long tets = 0;                               // tetrahedral route: tetrahedra walked
  int refine = 0;                              // and the split of the lattice cells
};

struct Result {
  double ks = 0;
  int nodes = 0;
  long steps = 0;
  double sim_seconds = 0, max_displacement = 0, folded_percent = 0;
  long d_texels = 0;
  double d_mib = 0, d_seconds = 0, d_error_voxels = 0;
  std::vector<Route> routes;
};

double median_ms(const std::function<double()>& frame, int frames) {
  frame();  // warm-up: llvmpipe compiles the shaders at their first draw
  std::vector<double> ms;
  for (int f = 0; f < frames; ++f) ms.push_back(frame());
  return median(ms);
}

std::string ks_text(double ks) { return fmt("%g", ks); }

}  // namespace

std::string run_stiffness_images(const StiffnessImageOptions& options, std::ostream& progress) {
  const auto t0 = Clock::now();
  auto say = [&](const std::string& line) {
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    progress << "stiffness images [" << fmt("%.0f", s) << " s] " << line << "\n";
    progress.flush();
  };
  const Scene base = load_scene(options.scene.string());
  if (base.boxes.size() != 1 || base.boxes[0].deformer.type != "simulation")
    throw Error(options.scene.string() +
                ": the stiffness images need one box with a simulation "
                "deformer");
  const Camera camera = base.camera ? *base.camera : Camera{};
  const fs::path image_dir = options.out / "images";
  fs::create_directories(image_dir);

  BakeSession session;  // the distance grid is baked once for every stiffness
  std::vector<Result> results;
  for (double ks : options.ks) {
    Scene scene = base;
    scene.boxes[0].deformer.ks = ks;
    Result r;
    r.ks = ks;
    std::ostringstream log;
    const PreparedScene prepared = prepare_scene(scene, log, session);
    const BakedBox& box = prepared.boxes[0];
    const SimulationReport& sim = *box.report.simulation;
    const SimulationBody& body = *sim.lattice;
    const std::vector<Eigen::Vector3d>& state = *sim.state;
    r.nodes = sim.body.nodes;
    r.steps = sim.steps;
    r.sim_seconds = box.report.stage(Stage::Simulation)->seconds;
    for (size_t n = 0; n < state.size(); ++n)
      r.max_displacement = std::max(r.max_displacement, (state[n] - body.rest[n]).norm());
    r.folded_percent = box.report.folds.box_volume > 0
                           ? 100.0 * box.report.folds.folded_volume / box.report.folds.box_volume
                           : 0.0;
    const StageReport* d = box.report.stage(Stage::Deformation);
    r.d_texels = static_cast<long>(d->resolution.prod());
    r.d_mib = d->bytes / 1048576.0;
    r.d_seconds = d->seconds;
    r.d_error_voxels = box.report.texture_error_voxels();
    say("ks " + ks_text(ks) + ": " + std::to_string(r.nodes) + " nodes, " +
        std::to_string(r.steps) + " steps in " + fmt("%.2f", r.sim_seconds) +
        " s, largest node displacement " + fmt("%.3g", r.max_displacement) + "; D " +
        std::to_string(d->resolution.x()) + "x" + std::to_string(d->resolution.y()) + "x" +
        std::to_string(d->resolution.z()) + " in " + fmt("%.2f", r.d_seconds) + " s");

    const Truth truth = ground_truth(scene, prepared, camera, options.size, options.size);
    const double threshold = 0.01 * truth.diagonal;
    const std::string stem = (image_dir / ("ks_" + ks_text(ks))).string();
    write_png(stem + "_truth.png", truth.image);

    // Image space: the deformation texture, ray cast.
    {
      gl::Renderer renderer;
      renderer.set_mesh(prepared.mesh());
      renderer.set_boxes(prepared.textures());
      gl::FrameStats stats;
      const Image image = renderer.render(camera, options.size, options.size, scene.render, &stats);
      write_png(stem + "_image.png", image);
      Route route{"image space", compare_images(image, truth.image, threshold)};
      route.frame_ms = frame_median(renderer, camera, options.timing_size, options.timing_size,
                                    scene.render, options.frames);
      route.gpu_mib = renderer.texture_bytes() / 1048576.0;
      r.routes.push_back(route);
    }

    // The tetrahedral route: the body's tetrahedra (cells split as render.tets.refine says, its
    // default: at most kTetAutoCellVoxels voxels) mapped by F and walked, surface mode.
    {
      TetDisplaySpec spec = scene.render.tets;
      spec.mode = "surface";
      const TetBody tet_body = build_tet_body(box, prepared.mesh(), spec);
      gl::TetSceneRenderer renderer(prepared.mesh(), {&box.textures}, {&tet_body}, spec);
      const Image image = renderer.render(camera, options.size, options.size, scene.render);
      write_png(stem + "_tets.png", image);
      Route route{"tet walk (surface)", compare_images(image, truth.image, threshold)};
      route.frame_ms = median_ms(
          [&] {
            gl::TetSceneStats stats;
            renderer.render(camera, options.timing_size, options.timing_size, scene.render, &stats);
            return stats.raster_ms + stats.walk_ms;
          },
          options.frames);
      route.gpu_mib = renderer.mesh_bytes() / 1048576.0;
      route.tets = renderer.tet_count();
      route.refine = tet_body.refine;
      r.routes.push_back(route);
    }

    // Object space: the vertices in the box bound to the body's boundary surface at rest.
    {
      const Mesh& mesh = prepared.mesh();
      const Box& b = box.textures.box;
      const BodySurface surface = simulation_body_surface(body, state, b, mesh);
      for (SurfaceBasis basis : {SurfaceBasis::Triangle, SurfaceBasis::Interpolated}) {
        const SurfaceBinding binding =
            bind_surface(mesh, surface.rest, surface.triangles, basis, nullptr, &surface.moves);
        const std::vector<Eigen::Vector3d> mapped = deform(binding, surface.moved);
        double worst = 0, sum = 0;
        long count = 0;
        for (size_t i = 0; i < mapped.size(); ++i) {
          if (binding.triangle[i] < 0) continue;
          const Eigen::Vector3d p = mesh.V.row(static_cast<Eigen::Index>(i)).transpose();
          const double e = (mapped[i] - b.to_object(box.deformer->forward(b.to_local(p)))).norm();
          worst = std::max(worst, e);
          sum += e;
          ++count;
        }
        gl::SurfaceMappingRenderer renderer;
        renderer.set_binding(binding, mesh);
        renderer.set_nodes(surface.moved);
        const double gpu_mib = renderer.gpu_bytes() / 1048576.0;
        const Image image = renderer.render(camera, options.size, options.size, scene.render);
        if (basis == SurfaceBasis::Interpolated) write_png(stem + "_object.png", image);
        Route route{std::string("object space (") + basis_name(basis) + ")",
                    compare_images(image, truth.image, threshold)};
        route.gpu_mib = gpu_mib;
        route.vertex_max = worst;
        route.vertex_mean = count ? sum / double(count) : 0.0;
        route.frame_ms = median_ms(
            [&] {
              gl::FrameStats stats;
              renderer.render(camera, options.timing_size, options.timing_size, scene.render,
                              &stats);
              return stats.milliseconds;
            },
            options.frames);
        r.routes.push_back(route);
      }
    }
    for (const Route& route : r.routes)
      say("ks " + ks_text(ks) + ", " + route.name + ": IoU " + fmt("%.4f", route.c.iou) + ", " +
          fmt("%.2f", 100 * route.c.fraction_over) + " % over 1 % of the diagonal, " +
          fmt("%.1f", route.frame_ms) + " ms at " + std::to_string(options.timing_size) + "²");
    results.push_back(std::move(r));
  }

  // images.csv
  std::ostringstream csv;
  csv << kStiffnessImagesCsvHeader << "\n";
  for (const Result& r : results)
    for (const Route& route : r.routes) {
      const bool image = route.name == "image space";
      csv << num(r.ks) << "," << route.name << "," << r.nodes << "," << r.steps << ","
          << num(r.sim_seconds) << "," << num(r.max_displacement) << "," << num(r.folded_percent)
          << "," << num(route.c.iou) << "," << num(100 * route.c.fraction_over) << ","
          << num(route.c.mean_depth_error) << "," << num(route.frame_ms) << ","
          << num(route.vertex_max) << "," << num(route.vertex_mean) << ","
          << (image ? std::to_string(r.d_texels) : "") << "," << (image ? num(r.d_mib) : "") << ","
          << (image ? num(r.d_seconds) : "") << "," << (image ? num(r.d_error_voxels) : "") << ","
          << num(route.gpu_mib) << "," << (route.tets ? std::to_string(route.tets) : "") << ","
          << (route.refine ? std::to_string(route.refine) : "") << "\n";
    }
  write_file_atomic((options.out / "images.csv").string(), csv.str());

  // images.svg: error against ks, per route.
  {
    chart::Chart c;
    c.title = "Image error against ks: " + options.scene.filename().string() +
              ", final state, against the exact F";
    chart::Panel over, iou;
    over.title = "pixels off by more than 1 % of the diagonal";
    over.x_label = "ks (force / unit)";
    over.y_label = "% of common pixels";
    over.y_floor = 0.01;
    iou.title = "silhouette";
    iou.x_label = "ks (force / unit)";
    iou.y_label = "1 - IoU";
    iou.y_floor = 1e-4;
    std::map<std::string, chart::Series> a, bseries;
    for (const Result& r : results)
      for (const Route& route : r.routes) {
        a[route.name].name = bseries[route.name].name = route.name;
        a[route.name].x.push_back(r.ks);
        a[route.name].y.push_back(100 * route.c.fraction_over);
        bseries[route.name].x.push_back(r.ks);
        bseries[route.name].y.push_back(1.0 - route.c.iou);
      }
    for (auto& [k, v] : a) over.series.push_back(v);
    for (auto& [k, v] : bseries) iou.series.push_back(v);
    c.panels = {over, iou};
    chart::write_svg((options.out / "images.svg").string(), c);
  }

  // The report's section.
  std::ostringstream md;
  md << "## Images against ks: image space, the tet walk and object space\n\n"
     << "`" << options.scene.generic_string()
     << "` with its `ks` replaced, final state; each route against the exact ground truth of "
        "the same state (the mesh split at the box faces, subdivided to a quarter voxel, mapped "
        "by the state's F, rasterised on the CPU) at "
     << options.size << "², depth threshold 1 % of the deformed mesh's diagonal. Image space: "
     << "the deformation texture ray cast. Object space: Mosegaard & Sørensen's mappings, the "
        "mesh's vertices in the box bound to the body's boundary surface at rest, moved in a "
        "vertex shader (vertex error: |mapped − F(vertex)| over those vertices, object units). "
        "Tet walk: the body's lattice cells split k³ (k in the last table), Kuhn tetrahedra mapped "
        "by F, carrying the mesh part's signed distance f at rest, walked by the tetrahedral ray "
        "caster (Tejada & Ertl 2005, section 5) in surface mode (f's zero set, linear per "
        "tetrahedron) and composited with the rasterised mesh outside the box. GPU memory: what "
        "each route holds for the box (image space: the distance grid and D; object space: the "
        "binding and the nodes; tet walk: the tetrahedra's topology, planes and gradients). "
        "Frame times: median of "
     << options.frames << " frames at " << options.timing_size
     << "² (llvmpipe here). Figures: `images.csv`, `images.svg`, `images/`.\n\n"
     << "| ks | largest node displacement | folded | route | IoU | > 1 % diag | mean depth "
        "error | vertex error max / mean | frame ms | GPU MiB |\n"
     << "| ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const Result& r : results)
    for (const Route& route : r.routes)
      md << "| " << ks_text(r.ks) << " | " << fmt("%.3g", r.max_displacement) << " | "
         << fmt("%.2g", r.folded_percent) << " % | " << route.name << " | "
         << fmt("%.4f", route.c.iou) << " | " << fmt("%.2f", 100 * route.c.fraction_over) << " % | "
         << fmt("%.3g", route.c.mean_depth_error) << " | "
         << (std::isnan(route.vertex_max)
                 ? std::string("-")
                 : fmt("%.3g", route.vertex_max) + " / " + fmt("%.3g", route.vertex_mean))
         << " | " << fmt("%.1f", route.frame_ms) << " | " << fmt("%.1f", route.gpu_mib) << " |\n";
  md << "\nThe image-space route's D per ks:\n\n| ks | D texels | MiB | bake s | interpolation "
        "error (voxels) |\n| ---: | ---: | ---: | ---: | ---: |\n";
  for (const Result& r : results)
    md << "| " << ks_text(r.ks) << " | " << r.d_texels << " | " << fmt("%.1f", r.d_mib) << " | "
       << fmt("%.2f", r.d_seconds) << " | " << fmt("%.3f", r.d_error_voxels) << " |\n";
  md << "\nThe tetrahedral route's mesh per ks:\n\n| ks | cells split | tetrahedra |\n| ---: | "
        "---: "
        "| ---: |\n";
  for (const Result& r : results)
    for (const Route& route : r.routes)
      if (route.tets > 0)
        md << "| " << ks_text(r.ks) << " | " << route.refine << "³ | " << route.tets << " |\n";
  md << "\n";
  return md.str();
}

}  // namespace raywarp
