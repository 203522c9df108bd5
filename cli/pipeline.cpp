#include "library/deformation_bake.h"
#include "cli/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <ostream>
#include <sstream>

#include "deformers/bend.h"
#include "deformers/box_cut.h"
#include "deformers/composed.h"
#include "deformers/control_points.h"
#include "deformers/incision.h"
#include "deformers/peel.h"
#include "deformers/twist.h"
#include "cli/format.h"
#include "library/bake_cache.h"
#include "library/depth_cube.h"
#include "base/error.h"
#include "library/implicit.h"

namespace raywarp {

namespace {

// Residual |F(p' + D(p')) - p'| above which a texel counts as not inverted, in implicit voxels.
constexpr double kResidualVoxels = 0.01;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string dims_string(const Eigen::Vector3i& d) {
  return std::to_string(d.x()) + "x" + std::to_string(d.y()) + "x" + std::to_string(d.z());
}

// Cache keys: every input of a bake, numbers exact.
class Key {
 public:
  Key& operator<<(const std::string& word) {
    text_ += word;
    text_ += ' ';
    return *this;
  }
  Key& operator<<(double x) { return *this << key_number(x); }
  Key& operator<<(int x) { return *this << std::to_string(x); }
  const std::string& str() const { return text_; }

 private:
  std::string text_;
};

std::string box_key(const Box& b) {
  Key k;
  k << "box";
  for (int i = 0; i < 3; ++i) k << b.centre[i];
  for (int i = 0; i < 3; ++i) k << b.half_extents[i];
  for (int i = 0; i < 9; ++i) k << b.rotation(i / 3, i % 3);
  return k.str();
}

std::string one_deformer_key(const DeformerSpec& d) {
  Key k;
  k << d.type << "axis" << d.axis << "angle" << d.angle_deg << "from" << d.from_axis << d.from_side
    << "thickness" << d.thickness << "radius" << d.radius << "hinge" << d.hinge << "depth"
    << d.depth << "opening" << d.opening << "sub";
  for (int i = 0; i < 3; ++i) k << d.sub_min[i] << d.sub_max[i];
  k << "wedge" << d.wedge_axis << d.wedge_from_deg << d.wedge_angle_deg << "points";
  for (const PointPair& p : d.points)
    for (int i = 0; i < 3; ++i) k << p.source[i] << p.target[i];
  k << "influence" << d.influence_radius << "pinned";
  for (bool b : d.pinned) k << (b ? 1 : 0);
  return k.str();
}

}  // namespace

std::string deformer_key(const BoxSpec& spec) {
  Key k;
  k << "half extents";
  for (int i = 0; i < 3; ++i) k << spec.box.half_extents[i];
  k << "\n" << one_deformer_key(spec.deformer);
  for (const DeformerSpec& d : spec.then) k << "\nthen" << one_deformer_key(d);
  return k.str();
}

namespace {

void store(BakeCache* cache, const std::string& kind, const std::string& key,
           const std::vector<char>& payload, std::ostream& log) {
  if (!cache) return;
  std::string error;
  if (!cache->put(kind, key, payload, &error))
    log << "warning: the bake cache " << cache->dir().string() << " cannot store a " << kind << " ("
        << error << "); it will be baked again next time\n";
}

std::vector<char> save_sdf(const DistanceGrid& g) {
  CacheWriter w;
  w.grid(g.grid);
  w.number(g.background);
  w.number(g.band_voxels);
  w.text(g.sign_method);
  w.integer(g.active_voxels);
  w.number(g.bake_seconds);
  return w.bytes();
}

bool load_sdf(BakeCache& cache, const std::string& key, DistanceGrid& g) {
  auto bytes = cache.get("sdf", key);
  if (!bytes) return false;
  CacheReader r(*bytes);
  DistanceGrid d;
  if (!r.grid(d.grid, kMemoryBudgetBytes)) return false;
  d.background = static_cast<float>(r.number());
  d.band_voxels = r.number();
  d.sign_method = r.text();
  d.active_voxels = r.integer();
  d.bake_seconds = r.number();
  if (!r.ok() || !r.at_end()) return false;
  g = std::move(d);
  return true;
}

// D with the figures measured on it, which cost as much as the bake.
struct DeformationRecord {
  DeformationTexture texture;
  double lipschitz = std::numeric_limits<double>::infinity();
  double texture_error = 0.0;
  FoldReport folds;
  InverseResidual residual;
};

std::vector<char> save_deformation(const DeformationRecord& d) {
  CacheWriter w;
  w.grid(d.texture.grid);
  w.number(d.texture.bake_seconds);
  w.number(d.lipschitz);
  w.number(d.texture_error);
  w.number(d.folds.folded_volume);
  w.number(d.folds.box_volume);
  w.number(d.residual.max);
  w.number(d.residual.mean);
  w.integer(d.residual.texels);
  w.integer(d.residual.over_tolerance);
  w.number(d.residual.tolerance);
  w.integer(d.residual.folded);
  return w.bytes();
}

bool load_deformation(BakeCache& cache, const std::string& key, DeformationRecord& d) {
  auto bytes = cache.get("deformation", key);
  if (!bytes) return false;
  CacheReader r(*bytes);
  DeformationRecord out;
  if (!r.grid(out.texture.grid, kMemoryBudgetBytes)) return false;
  out.texture.bake_seconds = r.number();
  out.lipschitz = r.number();
  out.texture_error = r.number();
  out.folds.folded_volume = r.number();
  out.folds.box_volume = r.number();
  out.residual.max = r.number();
  out.residual.mean = r.number();
  out.residual.texels = r.integer();
  out.residual.over_tolerance = r.integer();
  out.residual.tolerance = r.number();
  out.residual.folded = r.integer();
  if (!r.ok() || !r.at_end()) return false;
  d = std::move(out);
  return true;
}

std::vector<char> save_alpha(const AlphaMap& a) {
  CacheWriter w;
  w.grid(a.grid);
  w.number(a.bake_seconds);
  return w.bytes();
}

bool load_alpha(BakeCache& cache, const std::string& key, AlphaMap& a) {
  auto bytes = cache.get("alpha", key);
  if (!bytes) return false;
  CacheReader r(*bytes);
  AlphaMap out;
  if (!r.grid(out.grid, kMemoryBudgetBytes)) return false;
  out.bake_seconds = r.number();
  if (!r.ok() || !r.at_end()) return false;
  a = std::move(out);
  return true;
}

std::vector<char> save_step_bounds(const StepBounds& b) {
  CacheWriter w;
  w.grid(b.bricks);
  w.grid(b.sdf_bricks);
  w.integer(b.brick_cells);
  w.number(b.sdf_lipschitz);
  w.number(b.validity_lipschitz);
  return w.bytes();
}

bool load_step_bounds(BakeCache& cache, const std::string& key, StepBounds& b) {
  auto bytes = cache.get("bounds", key);
  if (!bytes) return false;
  CacheReader r(*bytes);
  StepBounds out;
  if (!r.grid(out.bricks, kMemoryBudgetBytes) || !r.grid(out.sdf_bricks, kMemoryBudgetBytes))
    return false;
  out.brick_cells = static_cast<int>(r.integer());
  out.sdf_lipschitz = r.number();
  out.validity_lipschitz = r.number();
  if (!r.ok() || !r.at_end()) return false;
  b = std::move(out);
  return true;
}

}  // namespace

std::vector<BoxTextures> PreparedScene::textures() const {
  std::vector<BoxTextures> out;
  for (const auto& b : boxes) out.push_back(b.textures);
  return out;
}

namespace {

std::shared_ptr<const Deformer> make_one(const DeformerSpec& d, const Box& box,
                                         std::vector<std::string>* warnings) {
  const Axis axis = static_cast<Axis>(d.axis);
  const Face from{static_cast<Axis>(d.from_axis), d.from_side};
  if (d.type == "twist") return make_twist(box.half_extents, axis, d.angle_deg);
  if (d.type == "bend") return make_bend(box.half_extents, axis, d.angle_deg);
  if (d.type == "peel")
    return make_peel(box.half_extents, axis, from, d.angle_deg, d.thickness, d.radius, d.hinge);
  if (d.type == "incision") return make_incision(box.half_extents, axis, from, d.depth, d.opening);
  if (d.type == "box_cut") {
    BoxCutParams params;
    params.sub_min = d.sub_min;
    params.sub_max = d.sub_max;
    params.wedge_axis = static_cast<Axis>(d.wedge_axis);
    params.wedge_from_deg = d.wedge_from_deg;
    params.wedge_angle_deg = d.wedge_angle_deg;
    return make_box_cut(box.half_extents, params);
  }
  if (d.type == "control_points") {
    std::vector<ControlPoint> points;
    for (const PointPair& p : d.points) points.push_back({p.source, p.target});
    return make_control_points(box.half_extents, std::move(points), d.influence_radius, d.pinned,
                               warnings);
  }
  throw Error("type = \"" + d.type +
              "\": must be one of twist, bend, peel, incision, box_cut, control_points");
}

}  // namespace

std::shared_ptr<const Deformer> make_deformer(const Scene& scene, size_t box_index,
                                              std::vector<std::string>* warnings) {
  const BoxSpec& spec = scene.boxes.at(box_index);
  const std::string field =
      scene.file.string() + ": boxes[" + std::to_string(box_index) + "].deformer";
  std::vector<std::shared_ptr<const Deformer>> parts;
  for (size_t i = 0; i <= spec.then.size(); ++i) {
    const DeformerSpec& d = i == 0 ? spec.deformer : spec.then[i - 1];
    try {
      parts.push_back(make_one(d, spec.box, warnings));
    } catch (const Error& e) {
      std::string where = field;
      if (!spec.then.empty()) where += '[' + std::to_string(i) + ']';
      where += ".";
      throw Error(where + e.what());
    }
  }
  if (parts.size() == 1) return parts[0];
  try {
    return make_composed(std::move(parts));
  } catch (const Error& e) {
    throw Error(field + e.what());
  }
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

PreparedScene prepare_scene(const Scene& scene, std::ostream& log, BakeCache* cache,
                            bool centre_on_lower_faces) {
  PreparedScene out;
  auto start = std::chrono::steady_clock::now();
  out.mesh = load_mesh(scene.mesh.string());
  std::string mesh_file_hash;
  auto mesh_hash = [&]() -> const std::string& {
    if (mesh_file_hash.empty()) mesh_file_hash = file_hash(scene.mesh);
    return mesh_file_hash;
  };
  out.stats = mesh_stats(out.mesh);
  log << "mesh: " << describe(out.stats) << " (" << fmt("%.2f", seconds_since(start)) << " s)\n";
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    const BoxSpec& spec = scene.boxes[i];
    const std::string tag = "box " + std::to_string(i) + ": ";
    PreparedBox box;
    box.deformer = make_deformer(scene, i, &box.warnings);
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
    if (box.deformer->has_cut() && spec.cut_mode == CutMode::ThickShell && implicit.type == "sdf") {
      const double voxel = 2.0 * spec.box.half_extents.maxCoeff() / implicit.resolution;
      const double needed = std::ceil(spec.shell_thickness / voxel) + 2.0;
      if (needed > implicit.band_voxels) {
        log << tag << "narrow band widened from " << fmt("%g", implicit.band_voxels) << " to "
            << fmt("%g", needed) << " voxels to hold the shell thickness\n";
        implicit.band_voxels = needed;
      }
    }
    const auto& sdf = box.textures.sdf;
    std::string sdf_key;
    if (implicit.type == "depth_cube") {
      // Not cached: the six maps bake in milliseconds (docs/depth_cube.md).
      box.textures.depth_cube = bake_depth_cube(out.mesh, spec.box, implicit.resolution);
      ++out.bakes;
      box.textures.uses_depth_cube = true;
      log << tag << describe(box.textures.depth_cube) << "\n";
    } else {
      sdf_key = (Key() << "distance grid\nmesh" << mesh_hash() << "\n"
                       << box_key(spec.box) << "\nresolution" << implicit.resolution << "band"
                       << implicit.band_voxels << "margin" << implicit.margin_voxels)
                    .str();
      if (!(cache && load_sdf(*cache, sdf_key, box.textures.sdf))) {
        box.textures.sdf =
            bake_distance_grid(out.mesh, spec.box, implicit, kMemoryBudgetBytes, progress);
        ++out.bakes;
        store(cache, "sdf", sdf_key, save_sdf(box.textures.sdf), log);
      } else {
        log << tag << "distance grid from the cache (" << cache->dir().string() << ")\n";
      }
      log << tag << "distance grid " << dims_string(sdf.grid.dims) << ", voxel "
          << fmt("%.4g", sdf.grid.spacing) << ", band " << fmt("%.3g", sdf.band_voxels)
          << " voxels, " << sdf.active_voxels << " in band, "
          << fmt("%.1f", sdf.grid.size() * 4.0 / (1 << 20)) << " MiB, sign by " << sdf.sign_method
          << " (" << fmt("%.2f", sdf.bake_seconds) << " s)\n";
    }
    // The implicit's voxel: the unit of steps, the seam and the figures below.
    const double voxel = implicit_spacing(box.textures);

    BoxTextures& tex = box.textures;
    tex.moves_nothing = box.deformer->moves_nothing();
    // A deformer that moves nothing needs no displacement: a minimal texture keeps the shader's
    // bindings uniform, and rays are cast over the box grown by kCapVoxels voxels.
    const std::string def_key =
        (Key() << "deformation\n"
               << deformer_key(spec) << "\nresolution"
               << (tex.moves_nothing ? 2 : spec.deformation_resolution)
               << (centre_on_lower_faces ? "centred on the lower faces" : "")
               << "residual tolerance" << kResidualVoxels * voxel)
            .str();
    DeformationRecord record;
    if (cache && load_deformation(*cache, def_key, record)) {
      log << tag << "deformation texture and its figures from the cache\n";
    } else {
      record.texture = bake_deformation(*box.deformer, spec.box.half_extents,
                                        tex.moves_nothing ? 2 : spec.deformation_resolution,
                                        centre_on_lower_faces && !tex.moves_nothing);
      if (!tex.moves_nothing) {
        record.lipschitz = displacement_lipschitz(*box.deformer, record.texture);
        record.texture_error = deformation_texture_error(*box.deformer, record.texture);
        record.residual =
            measure_inverse_residual(*box.deformer, record.texture, kResidualVoxels * voxel);
      }
      record.folds = measure_folds(*box.deformer, spec.box.half_extents);
      ++out.bakes;
      store(cache, "deformation", def_key, save_deformation(record), log);
    }
    tex.deformation = std::move(record.texture);
    const auto& def = tex.deformation;
    if (tex.moves_nothing) {
      const Eigen::Vector3d pad = Eigen::Vector3d::Constant(kCapVoxels * voxel);
      tex.region = Eigen::AlignedBox3d(-spec.box.half_extents - pad, spec.box.half_extents + pad);
      if (!tex.uses_depth_cube)  // within the distance grid
        tex.region =
            tex.region.intersection(Eigen::AlignedBox3d(sdf.grid.origin, sdf.grid.upper()));
      tex.lipschitz = 1.0;
      log << tag << "no displacement; rays cast over the box and " << fmt("%g", kCapVoxels)
          << " voxels beyond (" << fmt("%.2f", def.bake_seconds) << " s)\n";
    } else {
      tex.region = Eigen::AlignedBox3d(def.grid.origin, def.grid.upper());
      tex.lipschitz = record.lipschitz;
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
      const std::string alpha_key =
          (Key() << "alpha\n"
                 << deformer_key(spec) << "\nregion" << tex.region.min().x() << tex.region.min().y()
                 << tex.region.min().z() << tex.region.max().x() << tex.region.max().y()
                 << tex.region.max().z() << "\nresolution" << spec.alpha_resolution)
              .str();
      if (!(cache && load_alpha(*cache, alpha_key, tex.alpha))) {
        tex.alpha = bake_alpha(*box.deformer, tex.region, spec.alpha_resolution);
        ++out.bakes;
        store(cache, "alpha", alpha_key, save_alpha(tex.alpha), log);
      }
      const auto& a = tex.alpha;
      log << tag << cut_mode_name(spec.cut_mode) << " cut, alpha map " << dims_string(a.grid.dims)
          << ", texel " << fmt("%.4g", a.grid.spacing) << ", "
          << fmt("%.1f", a.grid.size() * 4.0 / (1 << 20)) << " MiB (" << fmt("%.2f", a.bake_seconds)
          << " s)\n";
    }

    if (!tex.moves_nothing) {
      box.texture_error = record.texture_error;
      box.residual = record.residual;
      const InverseResidual& res = record.residual;
      log << tag << "inverse residual |F(p' + D(p')) - p'| over " << res.texels
          << " valid texels: max " << fmt("%.3g", res.max) << ", mean " << fmt("%.3g", res.mean)
          << " units; " << res.over_tolerance << " over " << fmt("%.3g", res.tolerance) << " ("
          << fmt("%g", kResidualVoxels) << " voxel)\n";
      if (res.over_tolerance > 0) {
        std::ostringstream w;
        w << "the deformation texture does not invert the deformation at " << res.over_tolerance
          << " of " << res.texels << " texels (residual up to " << fmt("%.3g", res.max)
          << " units, over " << fmt("%g", kResidualVoxels) << " voxel";
        if (res.folded) w << "; " << res.folded << " texels lie where the deformation folds";
        w << "): those points have no preimage or Newton's method did not find it";
        box.warnings.push_back(w.str());
      }
      const double voxels = box.texture_error / voxel;
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
    box.folds = record.folds;
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
    double reach = scene.render.max_steps * scene.render.step_voxels * voxel;
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
      const std::string bounds_key =
          (Key() << "step bounds\n"
                 << sdf_key << "\n"
                 << def_key << (scene.render.texture_bits == 16 ? "16-bit" : "32-bit"))
              .str();
      if (!(cache && load_step_bounds(*cache, bounds_key, tex.step_bounds))) {
        tex.step_bounds = bake_step_bounds(tex.sdf, tex.deformation);
        ++out.bakes;
        store(cache, "bounds", bounds_key, save_step_bounds(tex.step_bounds), log);
      }
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
