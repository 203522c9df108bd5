#include "editor/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ostream>

#include "deformers/bend.h"
#include "deformers/box_cut.h"
#include "deformers/incision.h"
#include "deformers/peel.h"
#include "deformers/twist.h"
#include "editor/format.h"
#include "library/error.h"
#include "library/implicit.h"

namespace raywarp {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string dims_string(const Eigen::Vector3i& d) {
  return std::to_string(d.x()) + "x" + std::to_string(d.y()) + "x" + std::to_string(d.z());
}

}  // namespace

std::vector<BoxTextures> PreparedScene::textures() const {
  std::vector<BoxTextures> out;
  for (const auto& b : boxes) out.push_back(b.textures);
  return out;
}

std::shared_ptr<const Deformer> make_deformer(const Scene& scene, size_t box_index) {
  const BoxSpec& spec = scene.boxes.at(box_index);
  const std::string field =
      scene.file.string() + ": boxes[" + std::to_string(box_index) + "].deformer";
  Axis axis = static_cast<Axis>(spec.deformer.axis);
  try {
    if (spec.deformer.type == "twist")
      return make_twist(spec.box.half_extents, axis, spec.deformer.angle_deg);
    if (spec.deformer.type == "bend")
      return make_bend(spec.box.half_extents, axis, spec.deformer.angle_deg);
    const DeformerSpec& d = spec.deformer;
    const Face from{static_cast<Axis>(d.from_axis), d.from_side};
    if (d.type == "peel")
      return make_peel(spec.box.half_extents, axis, from, d.angle_deg, d.thickness, d.radius,
                       d.hinge);
    if (d.type == "incision")
      return make_incision(spec.box.half_extents, axis, from, d.depth, d.opening);
    if (d.type == "box_cut") {
      BoxCutParams params;
      params.sub_min = d.sub_min;
      params.sub_max = d.sub_max;
      params.wedge_axis = static_cast<Axis>(d.wedge_axis);
      params.wedge_from_deg = d.wedge_from_deg;
      params.wedge_angle_deg = d.wedge_angle_deg;
      return make_box_cut(spec.box.half_extents, params);
    }
  } catch (const Error& e) {
    throw Error(field + "." + e.what());
  }
  throw Error(field + ".type = \"" + spec.deformer.type +
              "\": must be one of twist, bend, peel, incision, box_cut");
}

double frame_median(gl::Renderer& renderer, const Camera& camera, int width, int height,
                    const RenderSettings& settings, int frames) {
  gl::FrameStats stats;
  renderer.render(camera, width, height, settings, &stats);
  std::vector<double> ms;
  for (int f = 0; f < frames; ++f) {
    renderer.render(camera, width, height, settings, &stats);
    ms.push_back(stats.milliseconds);
  }
  return median(ms);
}

OpenEdges open_edges_in_box(const Mesh& mesh, const Box& box) {
  OpenEdges out;
  for_each_edge_use(mesh, [&](int u, int w, int faces) {
    if (faces != 1 && faces < 3) return;
    if (box.contains(0.5 * (mesh.V.row(u) + mesh.V.row(w)).transpose()))
      ++(faces == 1 ? out.boundary : out.nonmanifold);
  });
  return out;
}

std::vector<std::string> torn_faces(const Mesh& mesh, const Box& box, const Deformer& deformer) {
  static const char* names[6] = {"-x", "+x", "-y", "+y", "-z", "+z"};
  auto identity = deformer.identity_faces();
  std::vector<Eigen::Vector3d> local(mesh.V.rows());
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    local[i] = box.to_local(mesh.V.row(i).transpose());
  bool crossed[6] = {false, false, false, false, false, false};
  const Eigen::Vector3d& h = box.half_extents;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    for (int e = 0; e < 3; ++e) {
      const Eigen::Vector3d& a = local[mesh.F(f, e)];
      const Eigen::Vector3d& b = local[mesh.F(f, (e + 1) % 3)];
      for (int face = 0; face < 6; ++face) {
        if (identity[face] || crossed[face]) continue;
        int axis = face / 2;
        double plane = (face % 2) ? h[axis] : -h[axis];
        double da = a[axis] - plane, db = b[axis] - plane;
        if ((da > 0) == (db > 0) || da == db) continue;
        Eigen::Vector3d x = a + (b - a) * (da / (da - db));
        bool inside = true;
        for (int k = 0; k < 3; ++k)
          if (k != axis && std::abs(x[k]) > h[k]) inside = false;
        crossed[face] = inside;
      }
    }
  }
  std::vector<std::string> out;
  for (int face = 0; face < 6; ++face)
    if (crossed[face]) out.push_back(names[face]);
  return out;
}

PreparedScene prepare_scene(const Scene& scene, std::ostream& log) {
  PreparedScene out;
  auto start = std::chrono::steady_clock::now();
  out.mesh = load_mesh(scene.mesh.string());
  out.stats = mesh_stats(out.mesh);
  log << "mesh: " << describe(out.stats) << " (" << fmt("%.2f", seconds_since(start)) << " s)\n";
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    const BoxSpec& spec = scene.boxes[i];
    const std::string tag = "box " + std::to_string(i) + ": ";
    PreparedBox box;
    box.deformer = make_deformer(scene, i);
    box.textures.box = spec.box;
    log << tag << box.deformer->describe() << "\n";

    // Progress on the log every quarter of each stage, once a bake has run for a second.
    int last_quarter = -1;
    std::string last_stage;
    const auto bake_start = std::chrono::steady_clock::now();
    Progress progress = [&](const char* stage, double fraction) {
      int quarter = static_cast<int>(fraction * 4.0);
      if ((stage != last_stage || quarter != last_quarter) && seconds_since(bake_start) > 1.0) {
        log << tag << "distance grid: " << stage << " " << 25 * quarter << " %\n" << std::flush;
        last_stage = stage;
        last_quarter = quarter;
      }
      return true;
    };
    // A thick shell reads f down to tau below the surface (eq. 7): the narrow band, beyond which
    // the grid holds only +-background, must reach past tau.
    ImplicitSpec implicit = spec.implicit;
    if (box.deformer->has_cut() && spec.cut_mode == CutMode::ThickShell) {
      const double voxel = 2.0 * spec.box.half_extents.maxCoeff() / implicit.resolution;
      const double needed = std::ceil(spec.shell_thickness / voxel) + 2.0;
      if (needed > implicit.band_voxels) {
        log << tag << "narrow band widened from " << fmt("%g", implicit.band_voxels) << " to "
            << fmt("%g", needed) << " voxels to hold the shell thickness\n";
        implicit.band_voxels = needed;
      }
    }
    box.textures.sdf =
        bake_distance_grid(out.mesh, spec.box, implicit, kMemoryBudgetBytes, progress);
    const auto& sdf = box.textures.sdf;
    log << tag << "distance grid " << dims_string(sdf.grid.dims) << ", voxel "
        << fmt("%.4g", sdf.grid.spacing) << ", band " << fmt("%.3g", sdf.band_voxels) << " voxels, "
        << sdf.active_voxels << " in band, " << fmt("%.1f", sdf.grid.size() * 4.0 / (1 << 20))
        << " MiB, sign by " << sdf.sign_method << " (" << fmt("%.2f", sdf.bake_seconds) << " s)\n";

    BoxTextures& tex = box.textures;
    tex.moves_nothing = box.deformer->moves_nothing();
    // A deformer that moves nothing needs no displacement: a minimal texture keeps the shader's
    // bindings uniform, and rays are cast over the box grown by kCapVoxels voxels.
    tex.deformation = bake_deformation(*box.deformer, spec.box.half_extents,
                                       tex.moves_nothing ? 2 : spec.deformation_resolution);
    const auto& def = tex.deformation;
    if (tex.moves_nothing) {
      const Eigen::Vector3d pad = Eigen::Vector3d::Constant(kCapVoxels * sdf.grid.spacing);
      tex.region = Eigen::AlignedBox3d((-spec.box.half_extents - pad).cwiseMax(sdf.grid.origin),
                                       (spec.box.half_extents + pad).cwiseMin(sdf.grid.upper()));
      tex.lipschitz = 1.0;
      log << tag << "no displacement; rays cast over the box and " << fmt("%g", kCapVoxels)
          << " voxels beyond (" << fmt("%.2f", def.bake_seconds) << " s)\n";
    } else {
      tex.region = Eigen::AlignedBox3d(def.grid.origin, def.grid.upper());
      tex.lipschitz = displacement_lipschitz(*box.deformer, def);
      log << tag << "deformation texture " << dims_string(def.grid.dims) << ", texel "
          << fmt("%.4g", def.grid.spacing) << ", "
          << fmt("%.1f", def.grid.size() * 16.0 / (1 << 20))
          << " MiB, |I + J_D| <= " << fmt("%.3g", tex.lipschitz) << " ("
          << fmt("%.2f", def.bake_seconds) << " s)\n";
    }
    if (box.deformer->has_cut()) {
      tex.has_cut = true;
      tex.cut_mode = spec.cut_mode;
      tex.shell_thickness = spec.shell_thickness;
      tex.alpha = bake_alpha(*box.deformer, tex.region, spec.alpha_resolution);
      const auto& a = tex.alpha;
      log << tag << cut_mode_name(spec.cut_mode) << " cut, alpha map " << dims_string(a.grid.dims)
          << ", texel " << fmt("%.4g", a.grid.spacing) << ", "
          << fmt("%.1f", a.grid.size() * 4.0 / (1 << 20)) << " MiB (" << fmt("%.2f", a.bake_seconds)
          << " s)\n";
    }

    if (!tex.moves_nothing) {
      box.texture_error = deformation_texture_error(*box.deformer, def);
      const double voxels = box.texture_error / sdf.grid.spacing;
      log << tag << "deformation texture error at cell centres: " << fmt("%.3g", box.texture_error)
          << " units (" << fmt("%.2g", voxels) << " voxels)\n";
      if (voxels > 1.0)
        box.warnings.push_back(
            "the deformation texture misplaces points by up to " + fmt("%.3g", box.texture_error) +
            " units (" + fmt("%.2g", voxels) +
            " voxels of the distance grid) between its texels: raise deformation.resolution "
            "(now " +
            std::to_string(spec.deformation_resolution) + ")");
    }
    box.folds = measure_folds(*box.deformer, spec.box.half_extents);
    if (box.folds.folds())
      box.warnings.push_back(
          "the deformation folds space in " + fmt("%.3g", box.folds.folded_volume) +
          " cubic units (" + fmt("%.2f", 100.0 * box.folds.folded_volume / box.folds.box_volume) +
          " % of the box, where det J <= 0); raywarp renders the non-folded branch there");
    for (const auto& face : torn_faces(out.mesh, spec.box, *box.deformer))
      box.warnings.push_back(
          "the mesh crosses box face " + face +
          ", where the deformation is not the identity: the surface tears there");
    if (const OpenEdges open = open_edges_in_box(out.mesh, spec.box); open.any())
      box.warnings.push_back(
          "the mesh is open or non-manifold inside the box (" + std::to_string(open.boundary) +
          " boundary and " + std::to_string(open.nonmanifold) +
          " non-manifold edges): its inside there is taken from the generalised winding "
          "number, and a sheet or fin with no inside of its own is not in the distance grid, so "
          "it does not show in the deformed part");
    double ray_length = tex.region.diagonal().norm();
    double reach = scene.render.max_steps * scene.render.step_voxels * sdf.grid.spacing;
    if (reach < ray_length)
      box.warnings.push_back("render.max_steps = " + std::to_string(scene.render.max_steps) +
                             " covers " + fmt("%.3g", reach) + " units of a ray, less than the " +
                             fmt("%.3g", ray_length) +
                             " across the deformed box: long rays stop early and miss");
    for (const auto& w : box.warnings) log << tag << "warning: " << w << "\n";
    if (scene.render.texture_bits == 16) {
      round_textures_to_half(box.textures);
      log << tag << "textures rounded to 16-bit floats\n";
    }
    if (scene.render.sampling == "bounded" && !tex.moves_nothing) {
      tex.step_bounds = bake_step_bounds(tex.sdf, tex.deformation);
      const StepBounds& sb = tex.step_bounds;
      auto range = [](const Grid3<float>& g) {
        const auto [lo, hi] = std::minmax_element(g.data.begin(), g.data.end());
        return "[" + fmt("%.3g", *lo) + ", " + fmt("%.3g", *hi) + "]";
      };
      log << tag << "bounded tracing: per brick of " << sb.brick_cells
          << "^3 cells and its neighbours, |grad f| in " << range(sb.sdf_bricks) << " (whole grid "
          << fmt("%.3g", sb.sdf_lipschitz) << "), |I + J_D| in " << range(sb.bricks) << "\n";
    }
    out.boxes.push_back(std::move(box));
  }
  return out;
}

}  // namespace raywarp
