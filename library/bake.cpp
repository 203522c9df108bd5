#include "library/bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "base/error.h"
#include "base/format.h"
#include "base/json_reader.h"
#include "deformers/composed.h"
#include "deformers/registry.h"
#include "library/cylindrical.h"
#include "library/depth_cube.h"
#include "library/implicit.h"
#include "library/mesh_pairs.h"
#include "library/sheets.h"
#include "library/triangle_bvh.h"
#include "library/winding.h"

namespace raywarp {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Cache keys: every input of a bake, numbers exact.
class Key {
 public:
  Key& operator<<(const std::string& word) {
    text_ += word;
    text_ += ' ';
    return *this;
  }
  Key& operator<<(const char* word) { return *this << std::string(word); }
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

template <class T>
std::uint64_t grid_bytes(const Grid3<T>& g) {
  return static_cast<std::uint64_t>(g.size()) * sizeof(T);
}

template <class T>
StageReport grid_stage(Stage stage, const Grid3<T>& g, double seconds, Source source) {
  StageReport s;
  s.stage = stage;
  s.source = source;
  s.resolution = g.dims;
  s.spacing = g.spacing;
  s.bytes = grid_bytes(g);
  s.seconds = seconds;
  return s;
}

// Serialisation of the stages for the disk cache.
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

// D with the figures measured on it, which cost as much as the bake.
struct DeformationRecord {
  DeformationTexture texture;
  double lipschitz = std::numeric_limits<double>::infinity();
  double texture_error = 0.0;
  ResolutionChoice choice;
  FoldReport folds;
  InverseResidual residual;
  AddedDetailFigures added_detail;  // texels > 0: measured (a list that adds detail)
};

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

// A with its measured error and how its layout was chosen.
struct AlphaRecord {
  AlphaMap map;
  double error = 0.0;
  ResolutionChoice choice;
};

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

// A simulation's last state (box frame) and what the run took.
struct SimulationRecord {
  std::vector<Eigen::Vector3d> positions;
  long steps = 0, cg_iterations = 0, cg_capped = 0;
  double seconds = 0.0;
};

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

// A from_mesh fit: the fitted lattice (box frame) and the report of the pairs and the fit.
struct FitRecord {
  std::vector<Eigen::Vector3d> positions;
  FromMeshReport report;
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();
};

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

}  // namespace

const char* stage_name(Stage stage) {
  switch (stage) {
    case Stage::DistanceGrid:
      return "distance grid";
    case Stage::DepthCube:
      return "depth cube";
    case Stage::Simulation:
      return "simulation";
    case Stage::Fit:
      return "from mesh fit";
    case Stage::Deformation:
      return "deformation texture";
    case Stage::Alpha:
      return "alpha map";
    case Stage::StepBounds:
      break;
  }
  return "step bounds";
}

const char* source_name(Source source) {
  switch (source) {
    case Source::Baked:
      return "baked";
    case Source::Memory:
      return "memory";
    case Source::Disk:
      break;
  }
  return "disk cache";
}

const StageReport* BakeReport::stage(Stage s) const {
  for (const StageReport& r : stages)
    if (r.stage == s) return &r;
  return nullptr;
}

std::vector<std::string> BakeReport::warning_messages() const {
  std::vector<std::string> out;
  for (const BakeWarning& w : warnings)
    if (w.code != "cache_store") out.push_back(w.message);
  return out;
}

MeshPtr load_mesh_handle(const std::filesystem::path& file) {
  const auto start = std::chrono::steady_clock::now();
  auto handle = std::make_shared<MeshHandle>();
  handle->file = file;
  handle->mesh = load_mesh(file.string());
  handle->stats = mesh_stats(handle->mesh);
  handle->hash = file_hash(file);
  handle->load_seconds = seconds_since(start);
  return handle;
}

BakeJob make_job(const Scene& scene, size_t box_index, MeshPtr mesh, bool centre_on_lower_faces) {
  BakeJob job;
  job.mesh = std::move(mesh);
  job.spec = scene.boxes.at(box_index);
  job.where = scene.file.string() + ": boxes[" + std::to_string(box_index) + "]";
  job.sampling = scene.render.sampling;
  job.texture_bits = scene.render.texture_bits;
  job.max_steps = scene.render.max_steps;
  job.step_voxels = scene.render.step_voxels;
  job.centre_on_lower_faces = centre_on_lower_faces;
  return job;
}

std::shared_ptr<const Deformer> make_box_deformer(const BoxSpec& spec, const std::string& where,
                                                  std::vector<std::string>* warnings) {
  const std::string field = where + ".deformer";
  std::vector<std::shared_ptr<const Deformer>> parts;
  for (size_t i = 0; i <= spec.then.size(); ++i) {
    const DeformerSpec& d = i == 0 ? spec.deformer : spec.then[i - 1];
    try {
      parts.push_back(make_deformer(d, spec.box.half_extents, warnings));
    } catch (const Error& e) {
      std::string at = field;
      if (!spec.then.empty()) at += '[' + std::to_string(i) + ']';
      throw Error(at + "." + e.what());
    }
  }
  if (parts.size() == 1) return parts[0];
  try {
    return make_composed(std::move(parts));
  } catch (const Error& e) {
    throw Error(field + e.what());
  }
}

std::shared_ptr<const Deformer> make_deformer(const Scene& scene, size_t box_index,
                                              std::vector<std::string>* warnings) {
  return make_box_deformer(scene.boxes.at(box_index),
                           scene.file.string() + ": boxes[" + std::to_string(box_index) + "]",
                           warnings);
}

std::string deformer_key(const BoxSpec& spec) {
  Key k;
  k << "half extents";
  for (int i = 0; i < 3; ++i) k << spec.box.half_extents[i];
  k << "\n" << deformer_key(spec.deformer);
  for (const DeformerSpec& d : spec.then) k << "\nthen" << deformer_key(d);
  return k.str();
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

namespace {

// Akenine-Moeller's separating-axis test of a triangle (corners in the box's frame) against the
// box [-h, h].
bool triangle_meets_box(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c, const Eigen::Vector3d& h) {
  auto separated = [&](const Eigen::Vector3d& axis) {
    const double pa = axis.dot(a), pb = axis.dot(b), pc = axis.dot(c);
    const double r = h.dot(axis.cwiseAbs());
    return std::min({pa, pb, pc}) > r || std::max({pa, pb, pc}) < -r;
  };
  for (int k = 0; k < 3; ++k)
    if (separated(Eigen::Vector3d::Unit(k))) return false;
  const Eigen::Vector3d edges[3] = {b - a, c - b, a - c};
  if (separated(edges[0].cross(edges[1]))) return false;
  for (const Eigen::Vector3d& e : edges)
    for (int k = 0; k < 3; ++k)
      if (separated(Eigen::Vector3d::Unit(k).cross(e))) return false;
  return true;
}

}  // namespace

bool box_holds_mesh(const Mesh& mesh, const Box& box) {
  std::vector<Eigen::Vector3d> local(static_cast<size_t>(mesh.V.rows()));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    local[static_cast<size_t>(i)] = box.to_local(mesh.V.row(i).transpose());
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    if (triangle_meets_box(local[mesh.F(f, 0)], local[mesh.F(f, 1)], local[mesh.F(f, 2)],
                           box.half_extents))
      return true;
  return WindingNumber(mesh).exact(box.centre) > 0.5;
}

std::vector<std::string> torn_faces(const Mesh& mesh, const Box& box, const Deformer& deformer) {
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
    if (crossed[face]) out.push_back(face_name(face_of(face)));
  return out;
}

// ---------------------------------------------------------------------------------------------
// The session.

struct BakeSession::Entry {
  std::string key;
  std::shared_ptr<const void> value;
  std::uint64_t bytes = 0;
};

BakeSession::BakeSession(BakeCache* disk, std::uint64_t memory_budget_bytes)
    : disk_(disk), budget_(memory_budget_bytes) {}

BakeSession::~BakeSession() = default;

MeshPtr BakeSession::mesh(const std::filesystem::path& file) {
  for (const MeshPtr& m : meshes_)
    if (m->file == file) return m;
  meshes_.push_back(load_mesh_handle(file));
  return meshes_.back();
}

std::shared_ptr<const void> BakeSession::find(const std::string& key) {
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->key == key) {
      entries_.splice(entries_.begin(), entries_, it);
      return entries_.front().value;
    }
  return nullptr;
}

void BakeSession::keep(const std::string& key, std::shared_ptr<const void> value,
                       std::uint64_t bytes) {
  if (bytes > budget_) return;
  entries_.push_front(Entry{key, std::move(value), bytes});
  memory_bytes_ += bytes;
  while (memory_bytes_ > budget_ && !entries_.empty()) {
    memory_bytes_ -= entries_.back().bytes;
    entries_.pop_back();
  }
}

namespace {

// The bytes a from_mesh target reads: the file, and for a glTF the buffers its "uri"s name
// beside it.
std::string target_hash(const std::string& file) {
  std::string h = file_hash(file);
  const std::filesystem::path path(file);
  if (path.extension() == ".gltf") {
    try {
      const nlohmann::json doc = read_json_file(path, "glTF file");
      if (doc.contains("buffers") && doc["buffers"].is_array())
        for (const auto& b : doc["buffers"])
          if (b.is_object() && b.contains("uri") && b["uri"].is_string()) {
            const std::string uri = b["uri"].get<std::string>();
            if (uri.rfind("data:", 0) == 0) continue;
            const std::filesystem::path buffer = path.parent_path() / uri;
            std::error_code ec;
            if (std::filesystem::is_regular_file(buffer, ec)) h += " " + file_hash(buffer);
          }
    } catch (const Error&) {
      // An unreadable glTF fails in the reader, with its message.
    }
  }
  return h;
}

}  // namespace

BakedBox BakeSession::bake(const BakeJob& job, Interrupter* interrupter) {
  if (!job.mesh) throw Error(job.where + ": no mesh");
  const BoxSpec& spec = job.spec;
  const Mesh& mesh = job.mesh->mesh;
  BakedBox out;
  BakeReport& report = out.report;
  std::vector<std::string> notes;
  // A simulation is built over the mesh part, after the implicit surface.
  const bool on_mesh = needs_mesh(spec.deformer);
  if (on_mesh && !spec.then.empty())
    throw Error(job.where + ".then: a " + spec.deformer.type +
                " deformer must be the box's only one (compose it with nothing)");
  if (!on_mesh) {
    out.deformer = make_box_deformer(spec, job.where, &notes);
    for (std::string& n : notes) report.warnings.push_back({"deformer_note", std::move(n)});
    report.deformer = out.deformer->describe();
  }
  report.parameters = describe_spec(spec.deformer);
  for (const DeformerSpec& d : spec.then) report.parameters += "; " + describe_spec(d);

  // Memory, then disk, then bake; stores what it baked in both. The value lives in memory as a
  // shared_ptr<const T>, so a hit copies it into the textures once.
  auto stage = [&](auto& value, const std::string& kind, const std::string& key, long& counter,
                   auto bake, auto save, auto load) -> Source {
    using T = std::decay_t<decltype(value)>;
    if (auto hit = find(key)) {
      value = *static_cast<const T*>(hit.get());
      ++counters_.memory_hits;
      return Source::Memory;
    }
    if (disk_) {
      if (auto bytes = disk_->get(kind, key); bytes && load(*bytes, value)) {
        ++counters_.disk_hits;
        keep(key, std::make_shared<const T>(value), value_bytes(value));
        return Source::Disk;
      }
    }
    value = bake();  // throws Cancelled before anything is stored
    ++counter;
    keep(key, std::make_shared<const T>(value), value_bytes(value));
    if (disk_) {
      std::string error;
      if (!disk_->put(kind, key, save(value), &error))
        report.warnings.push_back({"cache_store", "the bake cache " + disk_->dir().string() +
                                                      " cannot store a " + kind + " (" + error +
                                                      "); it will be baked again next time"});
    }
    return Source::Baked;
  };

  BoxTextures& tex = out.textures;
  tex.box = spec.box;

  ImplicitSpec implicit = spec.implicit;
  if (implicit.resolution == kAutoResolution) {
    // The probe takes milliseconds but runs on every bake: the session keeps its answer.
    const std::string key = (Key() << "implicit resolution\nmesh" << job.mesh->hash << "\n"
                                   << box_key(spec.box) << "\n"
                                   << implicit.type << "budget" << implicit.max_mib)
                                .str();
    if (auto hit = find(key)) {
      report.implicit_choice = *static_cast<const ImplicitChoice*>(hit.get());
    } else {
      report.implicit_choice = choose_implicit_resolution(mesh, spec.box, implicit, interrupter);
      keep(key, std::make_shared<const ImplicitChoice>(report.implicit_choice),
           sizeof(ImplicitChoice));
    }
    implicit.resolution = report.implicit_choice.resolution;
  }
  report.implicit_choice.resolution = implicit.resolution;
  // A thick shell reads f down to tau below the surface (eq. 7): the narrow band, beyond which
  // the grid holds only +-background, must reach past tau.
  if (out.deformer && out.deformer->has_cut() && spec.cut_mode == CutMode::ThickShell &&
      implicit.type == "sdf") {
    const double voxel = 2.0 * spec.box.half_extents.maxCoeff() / implicit.resolution;
    const double needed = std::ceil(spec.shell_thickness / voxel) + 2.0;
    if (needed > implicit.band_voxels) {
      report.band_widened_from = implicit.band_voxels;
      implicit.band_voxels = needed;
    }
  }
  std::string sdf_key;
  if (implicit.type == "depth_cube") {
    const std::string key = (Key() << "depth cube\nmesh" << job.mesh->hash << "\n"
                                   << box_key(spec.box) << "\nresolution" << implicit.resolution)
                                .str();
    // Kept in memory only: the six maps bake in milliseconds (docs/depth_cube.md).
    Source source = Source::Baked;
    if (auto hit = find(key)) {
      tex.depth_cube = *static_cast<const DepthCube*>(hit.get());
      ++counters_.memory_hits;
      source = Source::Memory;
    } else {
      tex.depth_cube = bake_depth_cube(mesh, spec.box, implicit.resolution, interrupter);
      ++counters_.depth_cube;
      keep(key, std::make_shared<const DepthCube>(tex.depth_cube), value_bytes(tex.depth_cube));
    }
    tex.uses_depth_cube = true;
    StageReport s;
    s.stage = Stage::DepthCube;
    s.source = source;
    s.resolution = Eigen::Vector3i(tex.depth_cube.maps[0].nu, tex.depth_cube.maps[0].nv, 6);
    s.spacing = Eigen::Vector3d::Constant(tex.depth_cube.spacing);
    s.bytes = tex.depth_cube.texture_bytes();
    s.seconds = tex.depth_cube.bake_seconds;
    report.stages.push_back(s);
  } else {
    auto bake_grid = [&] {
      sdf_key = (Key() << "distance grid\nmesh" << job.mesh->hash << "\n"
                       << box_key(spec.box) << "\nresolution" << implicit.resolution << "band"
                       << implicit.band_voxels << "margin" << implicit.margin_voxels << "sheets"
                       << kSheetHalfVoxels)
                    .str();
      return stage(
          tex.sdf, "sdf", sdf_key, counters_.distance_grid,
          [&] {
            return bake_distance_grid(mesh, spec.box, implicit, kMemoryBudgetBytes, interrupter);
          },
          save_sdf, load_sdf);
    };
    Source source = bake_grid();
    // A sheet's shell is as thick as the voxel makes it: an automatic grid with sheets in it is
    // baked again as fine as they ask (kSheetAutoResolution), unless they are stray faces (a
    // scan's loose fragments).
    if (ImplicitChoice& c = report.implicit_choice;
        c.automatic && tex.sdf.sheet_area_share >= kSheetAreaShare) {
      const int finer = sheet_resolution(spec.box, implicit);
      if (finer > implicit.resolution) {
        c.sheets_raised_from = implicit.resolution;
        c.wanted = std::max(c.wanted, kSheetAutoResolution);
        c.budget_bound = finer < c.wanted;
        c.resolution = implicit.resolution = finer;
        source = bake_grid();
      }
    }
    report.stages.push_back(
        grid_stage(Stage::DistanceGrid, tex.sdf.grid, tex.sdf.bake_seconds, source));
    report.band_voxels = tex.sdf.band_voxels;
    report.active_voxels = tex.sdf.active_voxels;
    report.sign_method = tex.sdf.sign_method;
  }
  const double voxel = implicit_spacing(tex);
  report.voxel = voxel;

  std::string simulation_key;
  if (on_mesh && spec.deformer.type == "from_mesh") {
    // A deformed copy of the mesh: the vertex pairs inside the box, fitted by the deformer. The
    // keys name the bytes of the copies the frame reads (and a glTF's buffers); the fitted
    // lattice is a stage of its own, so a cached fit neither reads the copy nor fits again.
    const DeformerSpec& d = spec.deformer;
    const int morph = d.morph < 0 ? -1 : static_cast<int>(d.morph);
    auto field_error = [&](const Error& e) {
      const std::string what = e.what();
      const bool names_field = what.rfind("frame", 0) == 0 || what.rfind("morph", 0) == 0;
      return Error(job.where + ".deformer." + (names_field ? "" : "target: ") + what);
    };
    std::vector<std::string> files;
    try {
      files = deformed_copy_files(d.target, d.frame);
    } catch (const Error& e) {
      throw field_error(e);
    }
    simulation_key = "\nfrom mesh" + job.mesh->hash + " target";
    for (const std::string& file : files) simulation_key += " " + target_hash(file);
    const std::string fit_key =
        (Key() << "from mesh fit, turns in steps\nmesh" << job.mesh->hash << "\n"
               << box_key(spec.box) << "\n"
               << simulation_key << "\n"
               << deformer_key(d))
            .str();
    const double cell = 2.0 * spec.box.half_extents.maxCoeff() / d.fit_resolution;
    const double bound = 2.0 * std::sqrt(3.0) * cell;
    const TriangleBvh bvh(mesh);
    SimulationInput part;
    part.signed_distance = [&](const Eigen::Vector3d& q) {
      const double dist = bvh.nearest_distance(spec.box.to_object(q), bound);
      return implicit_value(tex, q) > 0.0 ? dist : -dist;
    };
    const FromMeshParams params = from_mesh_params(d, spec.box.half_extents, part);
    std::unique_ptr<Deformer> fitted;
    FitRecord fit;
    const Source source = stage(
        fit, "from mesh fit", fit_key, counters_.fit,
        [&] {
          const auto started = std::chrono::steady_clock::now();
          const DeformedCopy copy = [&] {
            try {
              return read_deformed_copy(d.target, morph, d.weight, d.frame);
            } catch (const Error& e) {
              throw field_error(e);
            }
          }();
          const MeshPairs pairs = [&] {
            try {
              return mesh_pairs(job.mesh->file.string(), mesh, copy.vertices, copy.name, spec.box);
            } catch (const Error& e) {
              throw Error(job.where + ".deformer.target: " + e.what());
            }
          }();
          if (pairs.sources.empty())
            throw Error(job.where +
                        ".deformer.target: no vertex of the mesh lies in the box: nothing to fit");
          std::vector<PointPair> point_pairs(pairs.sources.size());
          for (size_t i = 0; i < point_pairs.size(); ++i)
            point_pairs[i] = {pairs.sources[i], pairs.targets[i]};
          FitRecord r;
          FromMeshFit figures;
          try {
            fitted = make_from_mesh(spec.box.half_extents, point_pairs, params, &figures,
                                    interrupter, &r.positions);
          } catch (const Error& e) {
            throw Error(job.where + ".deformer: " + e.what());
          }
          FromMeshReport& fm = r.report;
          fm.pairs = static_cast<long>(pairs.sources.size());
          fm.frames = copy.frames;
          fm.frame = std::max(d.frame, 0.0);
          fm.file_vertices = pairs.file_vertices;
          fm.mesh_vertices = pairs.mesh_vertices;
          fm.torn = pairs.torn;
          fm.largest_move = pairs.largest_move;
          fm.moved_outside = pairs.moved_outside;
          fm.fit_max_error = figures.max_error;
          fm.fit_rms_error = figures.rms_error;
          fm.largest_turn_deg = figures.largest_turn_deg;
          fm.turn_steps = figures.steps;
          fm.seconds = seconds_since(started);
          r.cells = figures.cells;
          return r;
        },
        save_fit, load_fit);
    if (!fitted) {
      try {
        fitted = from_mesh_fitted(spec.box.half_extents, params, fit.positions, fit.report.pairs,
                                  interrupter);
      } catch (const Error& e) {
        throw Error(job.where + ": the cached from_mesh fit does not fit the box: " + e.what());
      }
    }
    out.deformer = std::move(fitted);
    report.deformer = out.deformer->describe();
    report.from_mesh = fit.report;
    StageReport s;
    s.stage = Stage::Fit;
    s.source = source;
    s.resolution = fit.cells;
    s.spacing = (2.0 * spec.box.half_extents).cwiseQuotient(fit.cells.cast<double>().cwiseMax(1.0));
    s.bytes = value_bytes(fit);
    s.seconds = fit.report.seconds;
    report.stages.push_back(s);
    const FromMeshReport& fm = fit.report;
    if (fm.torn > 0)
      report.warnings.push_back(
          {"torn_target", std::to_string(fm.torn) +
                              " vertices the mesh joins are pulled apart by the target (it tears "
                              "the surface there): each is moved to the mean of its copies"});
    if (fm.moved_outside > 0)
      report.warnings.push_back(
          {"target_outside_box",
           std::to_string(fm.moved_outside) +
               " vertices outside the box move in the target: they are drawn at rest; grow the "
               "box to hold the whole deformation"});
  } else if (on_mesh) {
    const SimulationParams params = simulation_params(spec.deformer);
    auto key_for = [&](const DeformerSpec& d) {
      return (Key() << "simulation\nmesh" << job.mesh->hash << "\n"
                    << box_key(spec.box) << "\nimplicit"
                    << (sdf_key.empty() ? "depth cube " + std::to_string(implicit.resolution)
                                        : sdf_key)
                    << "\n"
                    << deformer_key(d))
          .str();
    };
    simulation_key = key_for(spec.deformer);
    // The part's signed distance: exact, from the triangles, with the implicit surface's sign.
    // Only the margin's band matters; farther answers stop at a bound.
    const double cell = 2.0 * spec.box.half_extents.maxCoeff() / params.resolution;
    const double bound = 2.0 * std::max(params.margin, std::sqrt(3.0) * cell) + cell;
    const TriangleBvh bvh(mesh);
    SimulationInput part;
    part.signed_distance = [&](const Eigen::Vector3d& q) {
      const double d = bvh.nearest_distance(spec.box.to_object(q), bound);
      return implicit_value(tex, q) > 0.0 ? d : -d;
    };
    std::vector<std::string> sim_notes;
    const auto started = std::chrono::steady_clock::now();
    Simulation sim = [&] {
      try {
        return Simulation(params, spec.box.half_extents, part, &sim_notes, interrupter);
      } catch (const Error& e) {
        throw Error(job.where + ".deformer." + e.what());
      }
    }();
    SimulationRecord state;
    const Source source = stage(
        state, "simulation", simulation_key, counters_.simulation,
        [&] {
          // Every keep_every-th state is stored under its own step count (memory and disk), so
          // a sequence of bakes at those counts runs the simulation once.
          auto keep_state = [&](long step, const std::vector<Eigen::Vector3d>& positions) {
            if (step == params.steps) return;  // the stage stores it
            DeformerSpec at = spec.deformer;
            at.sim_steps = static_cast<double>(step);
            SimulationRecord r;
            r.positions = positions;
            r.steps = step;
            r.cg_iterations = sim.stats().cg_iterations;
            r.cg_capped = sim.stats().cg_capped;
            r.seconds = seconds_since(started);
            const std::string key = key_for(at);
            keep(key, std::make_shared<const SimulationRecord>(r), value_bytes(r));
            if (disk_) disk_->put("simulation", key, save_simulation(r), nullptr);
          };
          try {
            sim.run(job.keep_every, job.keep_every > 0 ? Simulation::Keep(keep_state) : nullptr,
                    interrupter);
          } catch (const Error& e) {
            throw Error(job.where + ".deformer: " + e.what());
          }
          SimulationRecord r;
          r.positions = sim.positions();
          r.steps = sim.stats().steps;
          r.cg_iterations = sim.stats().cg_iterations;
          r.cg_capped = sim.stats().cg_capped;
          r.seconds = seconds_since(started);
          return r;
        },
        save_simulation, load_simulation);
    if (state.positions.size() != sim.rest().size())
      throw Error(job.where + ": the cached simulation state does not fit the body");
    out.deformer = sim.deformer(state.positions);
    for (std::string& n : sim_notes) report.warnings.push_back({"deformer_note", std::move(n)});
    report.deformer = out.deformer->describe();
    const SimulationStats& st = sim.stats();
    report.simulation =
        SimulationReport{st,
                         std::make_shared<const SimulationBody>(sim.body()),
                         std::make_shared<const std::vector<Eigen::Vector3d>>(state.positions),
                         state.steps,
                         state.cg_iterations,
                         state.cg_capped};
    StageReport s;
    s.stage = Stage::Simulation;
    s.source = source;
    s.resolution = st.cells;
    s.spacing = st.spacing;
    s.bytes = value_bytes(state);
    s.seconds = state.seconds;
    report.stages.push_back(s);
    if (state.cg_capped > 0)
      report.warnings.push_back(
          {"solver_cap", std::to_string(state.cg_capped) + " of " + std::to_string(state.steps) +
                             " implicit Euler solves stopped at the CG iteration cap above their "
                             "tolerance: the state is less accurate than asked (lower dt)"});
  }

  tex.moves_nothing = out.deformer->moves_nothing();
  report.moves_nothing = tex.moves_nothing;
  // A deformer that moves nothing needs no displacement: a minimal texture keeps the shader's
  // bindings uniform, and rays are cast over the box grown by kCapVoxels voxels.
  const bool automatic = !tex.moves_nothing && spec.deformation_resolution == kAutoResolution;
  const int resolution = tex.moves_nothing ? 2 : spec.deformation_resolution;
  const double target = kAutoErrorVoxels * voxel;
  const auto budget = static_cast<std::uint64_t>(spec.deformation_max_mib * double(1 << 20));
  const bool centred = job.centre_on_lower_faces && !tex.moves_nothing;
  // A cylindrical texture (library/cylindrical.h) covers the deformed box grown by two voxels.
  const MappingSpec& mapping = spec.mapping;
  const bool cylindrical_d = mapping.cylindrical && !tex.moves_nothing;
  if (mapping.cylindrical && job.centre_on_lower_faces)
    throw Error(job.where +
                ".mapping: a cylindrical texture is not read through a texture map M "
                "(the animation re-bakes every frame instead)");
  const Eigen::AlignedBox3d cylinder_region = [&] {
    Eigen::AlignedBox3d r = deformed_bounds(*out.deformer, spec.box.half_extents, 2.0 * voxel);
    if (tex.moves_nothing)
      r.extend(Eigen::AlignedBox3d(
          -spec.box.half_extents - Eigen::Vector3d::Constant(kCapVoxels * voxel),
          spec.box.half_extents + Eigen::Vector3d::Constant(kCapVoxels * voxel)));
    return r;
  }();
  const CylindricalDomain domain =
      cylindrical_domain(cylinder_region, mapping.axis, spec.box.half_extents);
  Key mapping_key;
  if (mapping.cylindrical)
    mapping_key << "cylindrical about" << mapping.axis << "angle texels" << mapping.angle_texels
                << "floor" << kAutoCylindricalFloor[0] << kAutoCylindricalFloor[1]
                << kAutoCylindricalFloor[2] << "domain" << domain.radius << domain.low
                << domain.high << "faces" << domain.faces << domain.face_low << domain.face_high;
  Key layout;
  if (automatic)
    layout << "auto, error" << target << "budget" << double(budget) << "floor"
           << kAutoFloorResolution;
  else
    layout << resolution;
  const std::string def_key =
      (Key() << "deformation\n"
             << deformer_key(spec) << simulation_key << "\nresolution" << layout.str()
             << (job.centre_on_lower_faces ? "centred on the lower faces" : "")
             << "residual tolerance" << kResidualVoxels * voxel
             << (cylindrical_d ? mapping_key.str() : std::string()))
          .str();
  DeformationRecord record;
  const Source def_source = stage(
      record, "deformation", def_key, counters_.deformation,
      [&] {
        DeformationRecord r;
        const Deformer& d = *out.deformer;
        const Eigen::Vector3d& h = spec.box.half_extents;
        if (cylindrical_d) {
          const Eigen::Vector3i floor(kAutoCylindricalFloor[0], kAutoCylindricalFloor[1],
                                      kAutoCylindricalFloor[2]);
          if (automatic) {
            AutoDeformation a = bake_cylindrical_deformation_auto(
                d, h, mapping.axis, domain, target, budget, floor, interrupter);
            r.texture = std::move(a.texture);
            r.texture_error = a.error;
            r.choice = a.choice;
          } else {
            const Eigen::Vector3i counts(mapping.angle_texels, resolution, resolution);
            r.texture = bake_cylindrical_deformation(d, mapping.axis, domain, counts, interrupter);
            r.texture_error =
                cylindrical_deformation_error(d, h, r.texture, mapping.axis, interrupter);
          }
          // No Lipschitz bound is measured: cylindrical textures never skip (skipping_pays).
          r.lipschitz = std::numeric_limits<double>::infinity();
          r.residual = measure_cylindrical_residual(d, h, r.texture, mapping.axis,
                                                    kResidualVoxels * voxel, interrupter);
          r.folds = measure_folds(d, h, 64, interrupter);
          return r;
        }
        if (automatic) {
          AutoDeformation a = bake_deformation_auto(d, spec.box.half_extents, target, budget,
                                                    kAutoFloorResolution, centred, interrupter);
          r.texture = std::move(a.texture);
          r.texture_error = a.error;
          r.choice = a.choice;
        } else {
          r.texture = bake_deformation(d, spec.box.half_extents, resolution, centred, interrupter);
          if (!tex.moves_nothing)
            r.texture_error = deformation_texture_error(d, r.texture, 2, interrupter);
        }
        if (!tex.moves_nothing) {
          r.lipschitz = displacement_lipschitz(d, r.texture, interrupter);
          r.residual = measure_inverse_residual(d, r.texture, kResidualVoxels * voxel, interrupter);
          if (const auto* added = dynamic_cast<const AddedDetail*>(&d))
            r.added_detail =
                measure_added_detail(*added, spec.box.half_extents, r.texture, interrupter);
        }
        r.folds = measure_folds(d, spec.box.half_extents, 64, interrupter);
        return r;
      },
      save_deformation, load_deformation);
  tex.deformation = std::move(record.texture);
  report.stages.push_back(grid_stage(Stage::Deformation, tex.deformation.grid,
                                     tex.deformation.bake_seconds, def_source));
  if (tex.moves_nothing) {
    const Eigen::Vector3d pad = Eigen::Vector3d::Constant(kCapVoxels * voxel);
    tex.region = Eigen::AlignedBox3d(-spec.box.half_extents - pad, spec.box.half_extents + pad);
    if (!tex.uses_depth_cube)  // within the distance grid
      tex.region =
          tex.region.intersection(Eigen::AlignedBox3d(tex.sdf.grid.origin, tex.sdf.grid.upper()));
    tex.lipschitz = 1.0;
  } else if (cylindrical_d) {
    tex.region = cylinder_region;
    tex.lipschitz = record.lipschitz;
  } else {
    tex.region = Eigen::AlignedBox3d(tex.deformation.grid.origin, tex.deformation.grid.upper());
    tex.lipschitz = record.lipschitz;
  }
  if (mapping.cylindrical) tex.cylindrical_axis = mapping.axis;
  report.lipschitz = tex.lipschitz;

  if (out.deformer->has_cut()) {
    tex.has_cut = true;
    tex.cut_mode = spec.cut_mode;
    tex.shell_thickness = spec.shell_thickness;
    const bool auto_alpha = spec.alpha_resolution == kAutoResolution;
    const auto alpha_budget = static_cast<std::uint64_t>(spec.alpha_max_mib * double(1 << 20));
    const double band = kAlphaBandVoxels * voxel;
    Key alpha_layout;
    if (auto_alpha)
      alpha_layout << "auto, error" << target << "band" << band << "budget" << double(alpha_budget)
                   << "floor" << kAutoAlphaFloorResolution;
    else
      alpha_layout << spec.alpha_resolution;
    const std::string alpha_key =
        (Key() << "alpha\n"
               << deformer_key(spec) << "\nregion" << tex.region.min().x() << tex.region.min().y()
               << tex.region.min().z() << tex.region.max().x() << tex.region.max().y()
               << tex.region.max().z() << "\nresolution" << alpha_layout.str() << mapping_key.str())
            .str();
    AlphaRecord alpha;
    const Source source = stage(
        alpha, "alpha", alpha_key, counters_.alpha,
        [&] {
          AlphaRecord r;
          if (mapping.cylindrical) {
            const Eigen::Vector3i floor(kAutoCylindricalFloor[0], kAutoCylindricalFloor[1],
                                        kAutoCylindricalFloor[2]);
            if (auto_alpha) {
              AutoAlpha a = bake_cylindrical_alpha_auto(*out.deformer, mapping.axis, domain, target,
                                                        band, alpha_budget, floor, interrupter);
              r.map = std::move(a.map);
              r.error = a.error;
              r.choice = a.choice;
            } else {
              const Eigen::Vector3i counts(mapping.angle_texels, spec.alpha_resolution,
                                           spec.alpha_resolution);
              r.map =
                  bake_cylindrical_alpha(*out.deformer, mapping.axis, domain, counts, interrupter);
              r.error =
                  cylindrical_alpha_error(*out.deformer, r.map, mapping.axis, band, interrupter);
            }
            return r;
          }
          if (auto_alpha) {
            AutoAlpha a = bake_alpha_auto(*out.deformer, tex.region, target, band, alpha_budget,
                                          kAutoAlphaFloorResolution, interrupter);
            r.map = std::move(a.map);
            r.error = a.error;
            r.choice = a.choice;
          } else {
            r.map = bake_alpha(*out.deformer, tex.region, spec.alpha_resolution, interrupter);
            r.error = alpha_map_error(*out.deformer, r.map, band, 1, interrupter);
          }
          return r;
        },
        save_alpha, load_alpha);
    tex.alpha = std::move(alpha.map);
    report.alpha_error = alpha.error;
    report.alpha_choice = alpha.choice;
    report.stages.push_back(
        grid_stage(Stage::Alpha, tex.alpha.grid, tex.alpha.bake_seconds, source));
  }

  if (!tex.moves_nothing) {
    report.texture_error = record.texture_error;
    report.deformation_choice = record.choice;
    report.residual = record.residual;
    const InverseResidual& res = record.residual;
    const bool added_detail = dynamic_cast<const AddedDetail*>(out.deformer.get()) != nullptr;
    if (added_detail) report.added_detail = record.added_detail;
    if (res.over_tolerance > 0 && !added_detail) {
      std::string w = "the deformation texture does not invert the deformation at " +
                      std::to_string(res.over_tolerance) + " of " + std::to_string(res.texels) +
                      " texels (residual up to " + fmt("%.3g", res.max) + " units, over " +
                      fmt("%g", kResidualVoxels) + " voxel";
      if (res.folded)
        w += "; " + std::to_string(res.folded) + " texels lie where the deformation folds";
      w += "): those points have no preimage or Newton's method did not find it";
      report.warnings.push_back({"inverse_residual", w});
    }
    const double voxels = report.texture_error_voxels();
    const std::string advice =
        automatic ? "raise deformation.max_mib (now " + fmt("%g", spec.deformation_max_mib) +
                        "; the automatic layout stopped " +
                        (record.choice.budget_bound
                             ? std::string("at that budget")
                             : "after " + std::to_string(record.choice.bakes) + " bakes") +
                        ")"
                  : "raise deformation.resolution (now " +
                        std::to_string(spec.deformation_resolution) + ") or set it to \"auto\"";
    if (voxels > 1.0)
      report.warnings.push_back(
          {"texture_coarse", "the deformation texture misplaces points by up to " +
                                 fmt("%.3g", report.texture_error) + " units (" +
                                 fmt("%.2g", voxels) +
                                 " voxels of the distance grid) between its texels: " + advice});
  }
  report.folds = record.folds;
  if (report.folds.folds())
    report.warnings.push_back(
        {"folds", "the deformation folds space in " + fmt("%.3g", report.folds.folded_volume) +
                      " cubic units (" +
                      fmt("%.2f", 100.0 * report.folds.folded_volume / report.folds.box_volume) +
                      " % of the box, where det J <= 0); raywarp renders the non-folded branch "
                      "there"});
  if (!box_holds_mesh(mesh, spec.box))
    report.warnings.push_back(
        {"empty_box",
         "the box holds no part of the mesh (no triangle meets it, and it is not "
         "inside the mesh): it deforms nothing; check its centre and size against "
         "the mesh's bounds"});
  for (const auto& face : torn_faces(mesh, spec.box, *out.deformer))
    report.warnings.push_back(
        {"torn_face", "the mesh crosses box face " + face +
                          ", where the deformation is not the identity: the surface tears there"});
  if (const OpenEdges open = open_edges_in_box(mesh, spec.box); open.any()) {
    std::string w = "the mesh is open or non-manifold inside the box (" +
                    std::to_string(open.boundary) + " boundary and " +
                    std::to_string(open.nonmanifold) +
                    " non-manifold edges): its inside there is taken from the generalised "
                    "winding number";
    if (tex.uses_depth_cube)
      w += ", and a depth cube draws no sheet that has no inside of its own";
    else if (tex.sdf.sheet_faces > 0)
      w += ", and the " + std::to_string(tex.sdf.sheet_faces) +
           " faces with no inside of their own (sheets, cards, fins) are drawn as shells " +
           fmt("%.3g", 2.0 * tex.sdf.sheet_half_thickness) + " units (" +
           fmt("%g", 2.0 * kSheetHalfVoxels) + " voxels) thick";
    report.warnings.push_back({"open_mesh", w});
  }
  const double ray_length = tex.region.diagonal().norm();
  const double reach = job.max_steps * job.step_voxels * voxel;
  if (reach < ray_length)
    report.warnings.push_back(
        {"max_steps_short", "render.max_steps = " + std::to_string(job.max_steps) + " covers " +
                                fmt("%.3g", reach) + " units of a ray, less than the " +
                                fmt("%.3g", ray_length) +
                                " across the deformed box: long rays stop early and miss"});
  if (job.texture_bits == 16) {
    round_textures_to_half(tex);
    report.half_precision = true;
  }
  if (traces_bounded(job.sampling, tex.has_cut, tex.moves_nothing)) {
    const std::string bounds_key =
        (Key() << "step bounds\n"
               << sdf_key << "\n"
               << def_key << (job.texture_bits == 16 ? "16-bit" : "32-bit"))
            .str();
    const Source source = stage(
        tex.step_bounds, "bounds", bounds_key, counters_.step_bounds,
        [&] { return bake_step_bounds(tex.sdf, tex.deformation, 8, interrupter); },
        save_step_bounds, load_step_bounds);
    const StepBounds& sb = tex.step_bounds;
    StageReport s = grid_stage(Stage::StepBounds, sb.bricks, 0.0, source);
    s.bytes += grid_bytes(sb.sdf_bricks);
    report.stages.push_back(s);
    report.brick_cells = sb.brick_cells;
    auto range = [](const Grid3<float>& g, double& lo, double& hi) {
      const auto [a, b] = std::minmax_element(g.data.begin(), g.data.end());
      lo = *a;
      hi = *b;
    };
    range(sb.sdf_bricks, report.sdf_bound_min, report.sdf_bound_max);
    range(sb.bricks, report.d_bound_min, report.d_bound_max);
    report.sdf_lipschitz = sb.sdf_lipschitz;
  }
  return out;
}

std::vector<BoxTextures> PreparedScene::textures() const {
  std::vector<BoxTextures> out;
  for (const auto& b : boxes) out.push_back(b.textures);
  return out;
}

PreparedScene bake_scene(const Scene& scene, BakeSession& session, bool centre_on_lower_faces,
                         Interrupter* interrupter) {
  PreparedScene out;
  out.handle = session.mesh(scene.mesh);
  const long before = session.counters().baked();
  for (size_t i = 0; i < scene.boxes.size(); ++i)
    out.boxes.push_back(
        session.bake(make_job(scene, i, out.handle, centre_on_lower_faces), interrupter));
  out.bakes = static_cast<int>(session.counters().baked() - before);
  return out;
}

}  // namespace raywarp
