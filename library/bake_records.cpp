#include "library/bake_records.h"

#include "library/bake_cache.h"
#include "library/scene.h"

namespace raywarp {

namespace {

void save_choice(CacheWriter& w, const ResolutionChoice& c) {
  w.integer(c.automatic);
  w.number(c.target);
  w.integer(static_cast<std::int64_t>(c.budget_bytes));
  w.integer(c.bakes);
  w.integer(c.budget_bound);
}

ResolutionChoice load_choice(CacheReader& r) {
  ResolutionChoice c;
  c.automatic = r.integer() != 0;
  c.target = r.number();
  c.budget_bytes = static_cast<std::uint64_t>(r.integer());
  c.bakes = static_cast<int>(r.integer());
  c.budget_bound = r.integer() != 0;
  return c;
}

}  // namespace

std::vector<char> save_sdf(const DistanceGrid& g) {
  CacheWriter w;
  w.grid(g.grid);
  w.number(g.background);
  w.number(g.band_voxels);
  w.text(g.sign_method);
  w.integer(g.active_voxels);
  w.integer(g.sheet_faces);
  w.number(g.sheet_half_thickness);
  w.number(g.sheet_area_share);
  w.number(g.bake_seconds);
  return w.bytes();
}

bool load_sdf(const std::vector<char>& bytes, DistanceGrid& g) {
  CacheReader r(bytes);
  DistanceGrid d;
  if (!r.grid(d.grid, kMemoryBudgetBytes)) return false;
  d.background = static_cast<float>(r.number());
  d.band_voxels = r.number();
  d.sign_method = r.text();
  d.active_voxels = r.integer();
  d.sheet_faces = r.integer();
  d.sheet_half_thickness = r.number();
  d.sheet_area_share = r.number();
  d.bake_seconds = r.number();
  if (!r.ok() || !r.at_end()) return false;
  g = std::move(d);
  return true;
}

std::vector<char> save_deformation(const DeformationRecord& d) {
  CacheWriter w;
  w.grid(d.texture.grid);
  w.number(d.texture.bake_seconds);
  w.number(d.lipschitz);
  w.number(d.texture_error);
  save_choice(w, d.choice);
  w.number(d.folds.folded_volume);
  w.number(d.folds.box_volume);
  w.number(d.residual.max);
  w.number(d.residual.mean);
  w.integer(d.residual.texels);
  w.integer(d.residual.over_tolerance);
  w.number(d.residual.tolerance);
  w.integer(d.residual.folded);
  w.integer(d.residual.in_cut);
  w.number(d.added_detail.difference_max);
  w.number(d.added_detail.difference_mean);
  w.integer(d.added_detail.texels);
  w.number(d.added_detail.box_diagonal);
  return w.bytes();
}

bool load_deformation(const std::vector<char>& bytes, DeformationRecord& d) {
  CacheReader r(bytes);
  DeformationRecord out;
  if (!r.grid(out.texture.grid, kMemoryBudgetBytes)) return false;
  out.texture.bake_seconds = r.number();
  out.lipschitz = r.number();
  out.texture_error = r.number();
  out.choice = load_choice(r);
  out.folds.folded_volume = r.number();
  out.folds.box_volume = r.number();
  out.residual.max = r.number();
  out.residual.mean = r.number();
  out.residual.texels = r.integer();
  out.residual.over_tolerance = r.integer();
  out.residual.tolerance = r.number();
  out.residual.folded = r.integer();
  out.residual.in_cut = r.integer();
  out.added_detail.difference_max = r.number();
  out.added_detail.difference_mean = r.number();
  out.added_detail.texels = r.integer();
  out.added_detail.box_diagonal = r.number();
  if (!r.ok() || !r.at_end()) return false;
  d = std::move(out);
  return true;
}

std::vector<char> save_alpha(const AlphaRecord& a) {
  CacheWriter w;
  w.grid(a.map.grid);
  w.number(a.map.bake_seconds);
  w.number(a.error);
  save_choice(w, a.choice);
  return w.bytes();
}

bool load_alpha(const std::vector<char>& bytes, AlphaRecord& a) {
  CacheReader r(bytes);
  AlphaRecord out;
  if (!r.grid(out.map.grid, kMemoryBudgetBytes)) return false;
  out.map.bake_seconds = r.number();
  out.error = r.number();
  out.choice = load_choice(r);
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

bool load_step_bounds(const std::vector<char>& bytes, StepBounds& b) {
  CacheReader r(bytes);
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

std::uint64_t value_bytes(const DeformationRecord& d) { return grid_bytes(d.texture.grid); }

std::uint64_t value_bytes(const DistanceGrid& g) { return grid_bytes(g.grid); }

std::uint64_t value_bytes(const AlphaRecord& a) { return grid_bytes(a.map.grid); }

std::uint64_t value_bytes(const StepBounds& b) {
  return grid_bytes(b.bricks) + grid_bytes(b.sdf_bricks);
}

std::uint64_t value_bytes(const DepthCube& c) { return c.texture_bytes(); }

std::vector<char> save_simulation(const SimulationRecord& s) {
  CacheWriter w;
  w.integer(static_cast<long>(s.positions.size()));
  for (const Eigen::Vector3d& p : s.positions)
    for (int i = 0; i < 3; ++i) w.number(p[i]);
  w.integer(s.steps);
  w.integer(s.cg_iterations);
  w.integer(s.cg_capped);
  w.number(s.seconds);
  return w.bytes();
}

bool load_simulation(const std::vector<char>& bytes, SimulationRecord& s) {
  CacheReader r(bytes);
  SimulationRecord out;
  const long n = r.integer();
  if (!r.ok() || n < 0 || n > kMaxSimulationNodes) return false;
  out.positions.resize(static_cast<size_t>(n));
  for (Eigen::Vector3d& p : out.positions)
    for (int i = 0; i < 3; ++i) p[i] = r.number();
  out.steps = r.integer();
  out.cg_iterations = r.integer();
  out.cg_capped = r.integer();
  out.seconds = r.number();
  if (!r.ok() || !r.at_end()) return false;
  for (const Eigen::Vector3d& p : out.positions)
    if (!p.allFinite()) return false;
  s = std::move(out);
  return true;
}

std::uint64_t value_bytes(const SimulationRecord& s) {
  return s.positions.size() * sizeof(Eigen::Vector3d);
}

std::vector<char> save_fit(const FitRecord& f) {
  CacheWriter w;
  w.integer(static_cast<long>(f.positions.size()));
  for (const Eigen::Vector3d& p : f.positions)
    for (int i = 0; i < 3; ++i) w.number(p[i]);
  const FromMeshReport& r = f.report;
  for (long v : {r.pairs, r.file_vertices, r.mesh_vertices, r.torn, r.moved_outside,
                 static_cast<long>(r.frames), static_cast<long>(r.turn_steps),
                 static_cast<long>(f.cells.x()), static_cast<long>(f.cells.y()),
                 static_cast<long>(f.cells.z())})
    w.integer(v);
  for (double v :
       {r.largest_move, r.fit_max_error, r.fit_rms_error, r.seconds, r.frame, r.largest_turn_deg})
    w.number(v);
  return w.bytes();
}

bool load_fit(const std::vector<char>& bytes, FitRecord& f) {
  CacheReader r(bytes);
  FitRecord out;
  // At most the samples of the finest lattice (from_mesh_fitted checks the count).
  constexpr long kMaxSamples = long(kFromMeshMaxResolution + 1) * (kFromMeshMaxResolution + 1) *
                               (kFromMeshMaxResolution + 1);
  const long n = r.integer();
  if (!r.ok() || n < 0 || n > kMaxSamples ||
      static_cast<std::size_t>(n) * 3 * sizeof(double) > bytes.size())
    return false;
  out.positions.resize(static_cast<size_t>(n));
  for (Eigen::Vector3d& p : out.positions)
    for (int i = 0; i < 3; ++i) p[i] = r.number();
  FromMeshReport& m = out.report;
  m.pairs = r.integer();
  m.file_vertices = r.integer();
  m.mesh_vertices = r.integer();
  m.torn = r.integer();
  m.moved_outside = r.integer();
  m.frames = static_cast<int>(r.integer());
  const long steps = r.integer();
  if (steps < 1 || steps > 1000000) return false;
  m.turn_steps = static_cast<int>(steps);
  for (int a = 0; a < 3; ++a) out.cells[a] = static_cast<int>(r.integer());
  m.largest_move = r.number();
  m.fit_max_error = r.number();
  m.fit_rms_error = r.number();
  m.seconds = r.number();
  m.frame = r.number();
  m.largest_turn_deg = r.number();
  if (!r.ok() || !r.at_end() || m.pairs < 1 || !std::isfinite(m.largest_turn_deg)) return false;
  for (const Eigen::Vector3d& p : out.positions)
    if (!p.allFinite()) return false;
  f = std::move(out);
  return true;
}

std::uint64_t value_bytes(const FitRecord& f) {
  return f.positions.size() * sizeof(Eigen::Vector3d) + sizeof(FitRecord);
}

}  // namespace raywarp
