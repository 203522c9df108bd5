#include "library/prepare.h"

#include <chrono>
#include <cmath>
#include <ostream>
#include <string>

#include "base/format.h"
#include "library/depth_cube.h"

namespace raywarp {

namespace {

std::string dims_string(const Eigen::Vector3i& d) {
  return std::to_string(d.x()) + "x" + std::to_string(d.y()) + "x" + std::to_string(d.z());
}

// A texel's side, or its three sides where they differ.
std::string spacing_string(const Eigen::Vector3d& s) {
  if (s.maxCoeff() - s.minCoeff() <= 1e-9 * s.maxCoeff()) return fmt("%.4g", s.x());
  return fmt("%.4g", s.x()) + "x" + fmt("%.4g", s.y()) + "x" + fmt("%.4g", s.z());
}

double mib(std::uint64_t bytes) { return double(bytes) / (1 << 20); }

}  // namespace

void print_report(std::ostream& log, const std::string& tag, const BakedBox& box,
                  const BakeSession& session) {
  const BakeReport& r = box.report;
  const BoxTextures& tex = box.textures;
  log << tag << r.deformer << "\n";
  if (r.band_widened_from > 0)
    log << tag << "narrow band widened from " << fmt("%g", r.band_widened_from) << " to "
        << fmt("%g", r.band_voxels) << " voxels to hold the shell thickness\n";
  auto from_cache = [&](const StageReport* s) { return s && s->source != Source::Baked; };
  if (const StageReport* s = r.stage(Stage::DepthCube)) {
    log << tag << describe(tex.depth_cube) << (s->source == Source::Memory ? " (from memory)" : "")
        << "\n";
  }
  if (const ImplicitChoice& c = r.implicit_choice; c.automatic) {
    log << tag << "implicit resolution auto: ";
    if (c.feature > 0)
      log << "feature size " << fmt("%.3g", c.feature) << " units (the "
          << fmt("%g", 100 * kFeatureQuantile) << "th percentile of " << c.hits
          << " chords across the solid, " << c.limbs << " on limbs, from " << c.samples
          << " points) for " << fmt("%g", kFeatureVoxels) << " voxels across";
    else
      log << "no chord across a solid from " << c.samples << " points (open sheets)";
    log << ": " << c.resolution;
    if (c.budget_bound)
      log << ", held to the budget of " << fmt("%g", mib(c.budget_bytes)) << " MiB (it asked for "
          << c.wanted << ")";
    else
      log << " within " << fmt("%g", mib(c.budget_bytes)) << " MiB";
    if (c.sheets_raised_from > 0)
      log << "; raised from " << c.sheets_raised_from << " for the sheets in the box (their "
          << "shells' outline within half a pixel of a 1920x1080 view of the box)";
    log << "\n";
  }
  if (const StageReport* s = r.stage(Stage::DistanceGrid)) {
    if (from_cache(s))
      log << tag << "distance grid from the "
          << (s->source == Source::Memory ? std::string("session's memory")
                                          : "cache (" + session.disk()->dir().string() + ")")
          << "\n";
    log << tag << "distance grid " << dims_string(s->resolution) << ", voxel "
        << fmt("%.4g", s->spacing.x()) << ", band " << fmt("%.3g", r.band_voxels) << " voxels, "
        << r.active_voxels << " in band, " << fmt("%.1f", mib(s->bytes)) << " MiB, sign by "
        << r.sign_method;
    if (tex.sdf.sheet_faces > 0)
      log << "; " << tex.sdf.sheet_faces << " faces with no inside drawn as shells "
          << fmt("%.3g", 2.0 * tex.sdf.sheet_half_thickness) << " units thick";
    log << " (" << fmt("%.2f", s->seconds) << " s)\n";
  }
  if (const StageReport* sim = r.stage(Stage::Simulation); sim && r.simulation) {
    const SimulationStats& b = r.simulation->body;
    log << tag << "simulation: " << b.nodes << " nodes, " << b.springs << " springs";
    if (b.tets > 0)
      log << ", " << b.tets << " tets (smallest dihedral " << fmt("%.3g", b.min_dihedral_deg)
          << " deg, aspect " << fmt("%.3g", b.max_aspect_ratio) << ")";
    log << " on " << dims_string(b.cells) << " cells, margin " << fmt("%.3g", b.margin) << ", mass "
        << fmt("%.4g", b.total_mass) << "; pinned "
        << (b.pinned_faces.empty() ? std::string("none") : b.pinned_faces) << " (" << b.pinned
        << " nodes), " << b.dragged << " dragged; " << r.simulation->steps << " steps";
    if (r.simulation->cg_iterations > 0)
      log << ", " << r.simulation->cg_iterations << " CG iterations";
    log << (from_cache(sim) ? ", state from the cache" : "") << " (" << fmt("%.2f", sim->seconds)
        << " s)\n";
  }
  if (r.from_mesh) {
    const FromMeshReport& f = *r.from_mesh;
    log << tag << "target";
    if (f.frames > 0) log << " frame " << fmt("%.4g", f.frame) << " of 0-" << f.frames - 1;
    log << ": " << f.pairs << " of the mesh's " << f.mesh_vertices << " vertices in the box ("
        << f.file_vertices << " in the file), largest move " << fmt("%.4g", f.largest_move)
        << "; fit |F(source) - target| max " << fmt("%.3g", f.fit_max_error) << ", rms "
        << fmt("%.3g", f.fit_rms_error) << " units";
    if (f.turn_steps > 1)
      log << "; the pairs turn up to " << fmt("%.0f", f.largest_turn_deg)
          << "° about one line: fitted in " << f.turn_steps << " steps";
    log << (from_cache(r.stage(Stage::Fit)) ? ", fit from the cache" : "") << " ("
        << fmt("%.2f", f.seconds) << " s)\n";
  }
  const StageReport* def = r.stage(Stage::Deformation);
  if (from_cache(def)) log << tag << "deformation texture and its figures from the cache\n";
  if (r.moves_nothing) {
    log << tag << "no displacement; rays cast over the box and " << fmt("%g", kCapVoxels)
        << " voxels beyond (" << fmt("%.2f", def->seconds) << " s)\n";
  } else {
    log << tag << "deformation texture " << dims_string(def->resolution) << ", texel "
        << spacing_string(def->spacing) << ", " << fmt("%.1f", mib(def->bytes)) << " MiB, "
        << (std::isfinite(r.lipschitz)
                ? "|I + J_D| <= " + fmt("%.3g", r.lipschitz)
                : std::string("cylindrical (angle, radius, height), no |I + J_D| bound: no "
                              "empty-space skipping"))
        << " (" << fmt("%.2f", def->seconds) << " s)\n";
    const ResolutionChoice& c = r.deformation_choice;
    if (c.automatic)
      log << tag << "deformation texture layout: auto, for an error of at most "
          << fmt("%g", kAutoErrorVoxels) << " voxel within " << fmt("%g", mib(c.budget_bytes))
          << " MiB: " << c.bakes << (c.bakes == 1 ? " bake" : " bakes")
          << (c.budget_bound ? ", held to the budget" : "") << "\n";
  }
  if (const StageReport* a = r.stage(Stage::Alpha))
    log << tag << cut_mode_name(tex.cut_mode) << " cut, alpha map " << dims_string(a->resolution)
        << ", texel " << spacing_string(a->spacing) << ", " << fmt("%.1f", mib(a->bytes))
        << " MiB (" << fmt("%.2f", a->seconds) << " s)\n";
  if (r.stage(Stage::Alpha)) {
    log << tag << "alpha map error near the cut face: " << fmt("%.3g", r.alpha_error) << " units ("
        << fmt("%.2g", r.voxel > 0 ? r.alpha_error / r.voxel : 0.0) << " voxels)";
    const ResolutionChoice& c = r.alpha_choice;
    if (c.automatic)
      log << "; layout auto, for at most " << fmt("%g", kAutoErrorVoxels) << " voxel within "
          << fmt("%g", mib(c.budget_bytes)) << " MiB: " << c.bakes
          << (c.bakes == 1 ? " bake" : " bakes") << (c.budget_bound ? ", held to the budget" : "");
    log << "\n";
  }
  if (!r.moves_nothing) {
    const InverseResidual& res = r.residual;
    log << tag << "inverse residual |F(p' + D(p')) - p'| over " << res.texels
        << " valid texels: max " << fmt("%.3g", res.max) << ", mean " << fmt("%.3g", res.mean)
        << " units; " << res.over_tolerance << " over " << fmt("%.3g", res.tolerance) << " ("
        << fmt("%g", kResidualVoxels) << " voxel)";
    if (res.in_cut > 0)
      log << "; " << res.in_cut
          << " valid texels in the cut left out (the region the cut empties has no preimage)";
    log << "\n";
    if (r.added_detail) {
      // The residual above is then the cost of adding the detail's inverse displacement to the
      // list's instead of composing them (deformers/composed.h).
      const AddedDetailFigures& a = *r.added_detail;
      const double diag = a.box_diagonal > 0 ? a.box_diagonal : 1.0;
      log << tag << "detail added to D, not composed: the inverse residual above ("
          << fmt("%.2g", 100.0 * res.max / diag) << " % of the box diagonal at most, "
          << fmt("%.2g", 100.0 * res.mean / diag)
          << " % on average) is its cost; |D - D_exact| max " << fmt("%.3g", a.difference_max)
          << ", mean " << fmt("%.3g", a.difference_mean)
          << " units (D_exact: the exact composed inverse)\n";
    }
    log << tag << "deformation texture error at cell centres: " << fmt("%.3g", r.texture_error)
        << " units (" << fmt("%.2g", r.texture_error_voxels()) << " voxels)\n";
  }
  for (const BakeWarning& w : r.warnings)
    log << (w.code == "cache_store" ? "" : tag) << "warning: " << w.message << "\n";
  if (r.half_precision) log << tag << "textures rounded to 16-bit floats\n";
  if (r.stage(Stage::StepBounds))
    log << tag << "bounded tracing: per brick of " << r.brick_cells
        << "^3 cells and its neighbours, |grad f| in [" << fmt("%.3g", r.sdf_bound_min) << ", "
        << fmt("%.3g", r.sdf_bound_max) << "] (whole grid " << fmt("%.3g", r.sdf_lipschitz)
        << "), |I + J_D| in [" << fmt("%.3g", r.d_bound_min) << ", " << fmt("%.3g", r.d_bound_max)
        << "]\n";
}

BakedBox bake_logged(BakeSession& session, const BakeJob& job, std::ostream& log,
                     const std::string& tag) {
  // Progress on the log every quarter of each stage, once a bake has run for a second.
  int last_quarter = -1;
  std::string last_stage;
  const auto start = std::chrono::steady_clock::now();
  Interrupter progress([&](const std::string& stage, double fraction) {
    const int quarter = static_cast<int>(fraction * 4.0);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if ((stage != last_stage || quarter != last_quarter) && seconds > 1.0) {
      log << tag << stage << " " << 25 * quarter << " %\n" << std::flush;
      last_stage = stage;
      last_quarter = quarter;
    }
  });
  BakedBox box = session.bake(job, &progress);
  print_report(log, tag, box, session);
  return box;
}

PreparedScene prepare_scene(const Scene& scene, std::ostream& log, BakeSession& session,
                            bool centre_on_lower_faces) {
  PreparedScene out;
  out.handle = session.mesh(scene.mesh);
  log << "mesh: " << describe(out.stats()) << " (" << fmt("%.2f", out.handle->load_seconds)
      << " s)\n";
  const long before = session.counters().baked();
  for (size_t i = 0; i < scene.boxes.size(); ++i)
    out.boxes.push_back(bake_logged(session, make_job(scene, i, out.handle, centre_on_lower_faces),
                                    log, "box " + std::to_string(i) + ": "));
  out.bakes = static_cast<int>(session.counters().baked() - before);
  return out;
}

PreparedScene prepare_scene(const Scene& scene, std::ostream& log, BakeCache* cache,
                            bool centre_on_lower_faces) {
  BakeSession session(cache);
  return prepare_scene(scene, log, session, centre_on_lower_faces);
}

}  // namespace raywarp
