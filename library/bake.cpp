#include "library/bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "base/clock.h"
#include "base/error.h"
#include "base/format.h"
#include "base/json_reader.h"
#include "deformers/composed.h"
#include "deformers/registry.h"
#include "library/bake_records.h"
#include "library/cylindrical.h"
#include "library/depth_cube.h"
#include "library/implicit.h"
#include "library/mesh_pairs.h"
#include "library/sheets.h"
#include "library/triangle_bvh.h"
#include "library/winding.h"

namespace raywarp {

namespace {

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

namespace {

// The automatic cylindrical layouts' floor (angle, radius, height texels).
Eigen::Vector3i cylindrical_floor() {
  return {kAutoCylindricalFloor[0], kAutoCylindricalFloor[1], kAutoCylindricalFloor[2]};
}

}  // namespace

// One box's bake: the stages in order, each a member function that reads what the stages
// before it left (docs/architecture.md, "The bake pipeline"). Each stage goes through cached():
// the session's memory, then the disk cache, then the bake.
class BoxBake {
 public:
  BoxBake(BakeSession& session, const BakeJob& job, Interrupter* interrupter)
      : session_(session),
        job_(job),
        spec_(job.spec),
        mesh_(job.mesh->mesh),
        interrupter_(interrupter),
        on_mesh_(needs_mesh(job.spec.deformer)) {}

  BakedBox run() {
    analytic_deformer();
    implicit_surface();
    if (on_mesh_ && spec_.deformer.type == "from_mesh")
      fit();
    else if (on_mesh_)
      simulation();
    deformation();
    if (out_.deformer->has_cut()) alpha();
    texture_warnings();
    mesh_warnings();
    if (job_.texture_bits == 16) {
      round_textures_to_half(tex_);
      report_.half_precision = true;
    }
    if (traces_bounded(job_.sampling, tex_.has_cut, tex_.moves_nothing)) step_bounds();
    return std::move(out_);
  }

 private:
  template <class T, class Bake, class Save, class Load>
  Source cached(T& value, const std::string& kind, const std::string& key, long& counter, Bake bake,
                Save save, Load load);
  void analytic_deformer();
  void implicit_surface();
  void implicit_resolution();
  void depth_cube();
  void distance_grid();
  void fit();
  void simulation();
  void deformation_layout();
  void deformation();
  void alpha();
  void texture_warnings();
  void mesh_warnings();
  void step_bounds();
  SimulationInput part_distance(double bound, const TriangleBvh& bvh) const;

  BakeSession& session_;
  const BakeJob& job_;
  const BoxSpec& spec_;
  const Mesh& mesh_;
  Interrupter* interrupter_;
  const bool on_mesh_;  // a simulation or a fit, built over the mesh part after the implicit
  BakedBox out_;
  BakeReport& report_ = out_.report;
  BoxTextures& tex_ = out_.textures;
  // What the stages hand on.
  ImplicitSpec implicit_;
  double voxel_ = 0.0;
  std::string sdf_key_, simulation_key_, mapping_key_, def_key_;
  DeformationRecord record_;
  bool automatic_ = false;  // D's layout chosen for a target error
  bool cylindrical_d_ = false;
  double target_ = 0.0;  // the automatic layouts' target error (units)
  Eigen::AlignedBox3d cylinder_region_;
  CylindricalDomain domain_;
};

// Memory, then disk, then bake; stores what it baked in both. The value lives in memory as a
// shared_ptr<const T>, so a hit copies it into the textures once.
template <class T, class Bake, class Save, class Load>
Source BoxBake::cached(T& value, const std::string& kind, const std::string& key, long& counter,
                       Bake bake, Save save, Load load) {
  if (auto hit = session_.find(key)) {
    value = *static_cast<const T*>(hit.get());
    ++session_.counters_.memory_hits;
    return Source::Memory;
  }
  BakeCache* disk = session_.disk_;
  if (disk) {
    if (auto bytes = disk->get(kind, key); bytes && load(*bytes, value)) {
      ++session_.counters_.disk_hits;
      session_.keep(key, std::make_shared<const T>(value), value_bytes(value));
      return Source::Disk;
    }
  }
  value = bake();  // throws Cancelled before anything is stored
  ++counter;
  session_.keep(key, std::make_shared<const T>(value), value_bytes(value));
  if (disk) {
    std::string error;
    if (!disk->put(kind, key, save(value), &error))
      report_.warnings.push_back({"cache_store", "the bake cache " + disk->dir().string() +
                                                     " cannot store a " + kind + " (" + error +
                                                     "); it will be baked again next time"});
  }
  return Source::Baked;
}

// An analytic deformer (or a composed list) is made from the box's spec; a simulation or a fit
// is made by its own stage, after the implicit surface.
void BoxBake::analytic_deformer() {
  if (on_mesh_ && !spec_.then.empty())
    throw Error(job_.where + ".then: a " + spec_.deformer.type +
                " deformer must be the box's only one (compose it with nothing)");
  if (!on_mesh_) {
    std::vector<std::string> notes;
    out_.deformer = make_box_deformer(spec_, job_.where, &notes);
    for (std::string& n : notes) report_.warnings.push_back({"deformer_note", std::move(n)});
    report_.deformer = out_.deformer->describe();
  }
  report_.parameters = describe_spec(spec_.deformer);
  for (const DeformerSpec& d : spec_.then) report_.parameters += "; " + describe_spec(d);
}

// The implicit surface: its resolution, then the depth cube or the distance grid.
void BoxBake::implicit_surface() {
  tex_.box = spec_.box;
  implicit_ = spec_.implicit;
  implicit_resolution();
  if (implicit_.type == "depth_cube")
    depth_cube();
  else
    distance_grid();
  voxel_ = implicit_spacing(tex_);
  report_.voxel = voxel_;
}

void BoxBake::implicit_resolution() {
  if (implicit_.resolution == kAutoResolution) {
    // The probe takes milliseconds but runs on every bake: the session keeps its answer.
    const std::string key = (Key() << "implicit resolution\nmesh" << job_.mesh->hash << "\n"
                                   << box_key(spec_.box) << "\n"
                                   << implicit_.type << "budget" << implicit_.max_mib)
                                .str();
    if (auto hit = session_.find(key)) {
      report_.implicit_choice = *static_cast<const ImplicitChoice*>(hit.get());
    } else {
      report_.implicit_choice =
          choose_implicit_resolution(mesh_, spec_.box, implicit_, interrupter_);
      session_.keep(key, std::make_shared<const ImplicitChoice>(report_.implicit_choice),
                    sizeof(ImplicitChoice));
    }
    implicit_.resolution = report_.implicit_choice.resolution;
  }
  report_.implicit_choice.resolution = implicit_.resolution;
  // A thick shell reads f down to tau below the surface (eq. 7): the narrow band, beyond which
  // the grid holds only +-background, must reach past tau.
  if (out_.deformer && out_.deformer->has_cut() && spec_.cut_mode == CutMode::ThickShell &&
      implicit_.type == "sdf") {
    const double voxel = 2.0 * spec_.box.half_extents.maxCoeff() / implicit_.resolution;
    const double needed = std::ceil(spec_.shell_thickness / voxel) + 2.0;
    if (needed > implicit_.band_voxels) {
      report_.band_widened_from = implicit_.band_voxels;
      implicit_.band_voxels = needed;
    }
  }
}

// Kept in memory only: the six maps bake in milliseconds (docs/depth_cube.md).
void BoxBake::depth_cube() {
  const std::string key = (Key() << "depth cube\nmesh" << job_.mesh->hash << "\n"
                                 << box_key(spec_.box) << "\nresolution" << implicit_.resolution)
                              .str();
  Source source = Source::Baked;
  if (auto hit = session_.find(key)) {
    tex_.depth_cube = *static_cast<const DepthCube*>(hit.get());
    ++session_.counters_.memory_hits;
    source = Source::Memory;
  } else {
    tex_.depth_cube = bake_depth_cube(mesh_, spec_.box, implicit_.resolution, interrupter_);
    ++session_.counters_.depth_cube;
    session_.keep(key, std::make_shared<const DepthCube>(tex_.depth_cube),
                  value_bytes(tex_.depth_cube));
  }
  tex_.uses_depth_cube = true;
  StageReport s;
  s.stage = Stage::DepthCube;
  s.source = source;
  s.resolution = Eigen::Vector3i(tex_.depth_cube.maps[0].nu, tex_.depth_cube.maps[0].nv, 6);
  s.spacing = Eigen::Vector3d::Constant(tex_.depth_cube.spacing);
  s.bytes = tex_.depth_cube.texture_bytes();
  s.seconds = tex_.depth_cube.bake_seconds;
  report_.stages.push_back(s);
}

void BoxBake::distance_grid() {
  auto bake_grid = [&] {
    sdf_key_ = (Key() << "distance grid\nmesh" << job_.mesh->hash << "\n"
                      << box_key(spec_.box) << "\nresolution" << implicit_.resolution << "band"
                      << implicit_.band_voxels << "margin" << implicit_.margin_voxels << "sheets"
                      << kSheetHalfVoxels)
                   .str();
    return cached(
        tex_.sdf, "sdf", sdf_key_, session_.counters_.distance_grid,
        [&] {
          return bake_distance_grid(mesh_, spec_.box, implicit_, kMemoryBudgetBytes, interrupter_);
        },
        save_sdf, load_sdf);
  };
  Source source = bake_grid();
  // A sheet's shell is as thick as the voxel makes it: an automatic grid with sheets in it is
  // baked again as fine as they ask (kSheetAutoResolution), unless they are stray faces (a
  // scan's loose fragments).
  if (ImplicitChoice& c = report_.implicit_choice;
      c.automatic && tex_.sdf.sheet_area_share >= kSheetAreaShare) {
    const int finer = sheet_resolution(spec_.box, implicit_);
    if (finer > implicit_.resolution) {
      c.sheets_raised_from = implicit_.resolution;
      c.wanted = std::max(c.wanted, kSheetAutoResolution);
      c.budget_bound = finer < c.wanted;
      c.resolution = implicit_.resolution = finer;
      source = bake_grid();
    }
  }
  report_.stages.push_back(
      grid_stage(Stage::DistanceGrid, tex_.sdf.grid, tex_.sdf.bake_seconds, source));
  report_.band_voxels = tex_.sdf.band_voxels;
  report_.active_voxels = tex_.sdf.active_voxels;
  report_.sign_method = tex_.sdf.sign_method;
}

// The part's signed distance for a fit or a simulation: exact, from the triangles, with the
// implicit surface's sign. Only a band near the surface matters; farther answers stop at `bound`.
SimulationInput BoxBake::part_distance(double bound, const TriangleBvh& bvh) const {
  SimulationInput part;
  part.signed_distance = [this, bound, &bvh](const Eigen::Vector3d& q) {
    const double d = bvh.nearest_distance(spec_.box.to_object(q), bound);
    return implicit_value(tex_, q) > 0.0 ? d : -d;
  };
  return part;
}

// A deformed copy of the mesh: the vertex pairs inside the box, fitted by the deformer. The keys
// name the bytes of the copies the frame reads (and a glTF's buffers); the fitted lattice is a
// stage of its own, so a cached fit neither reads the copy nor fits again.
void BoxBake::fit() {
  const DeformerSpec& d = spec_.deformer;
  const int morph = d.morph < 0 ? -1 : static_cast<int>(d.morph);
  auto field_error = [&](const Error& e) {
    const std::string what = e.what();
    const bool names_field = what.rfind("frame", 0) == 0 || what.rfind("morph", 0) == 0;
    return Error(job_.where + ".deformer." + (names_field ? "" : "target: ") + what);
  };
  std::vector<std::string> files;
  try {
    files = deformed_copy_files(d.target, d.frame);
  } catch (const Error& e) {
    throw field_error(e);
  }
  simulation_key_ = "\nfrom mesh" + job_.mesh->hash + " target";
  for (const std::string& file : files) {
    simulation_key_ += ' ';
    simulation_key_ += target_hash(file);
  }
  const std::string fit_key =
      (Key() << "from mesh fit, turns in steps\nmesh" << job_.mesh->hash << "\n"
             << box_key(spec_.box) << "\n"
             << simulation_key_ << "\n"
             << deformer_key(d))
          .str();
  const double cell = 2.0 * spec_.box.half_extents.maxCoeff() / d.fit_resolution;
  const TriangleBvh bvh(mesh_);
  const SimulationInput part = part_distance(2.0 * std::sqrt(3.0) * cell, bvh);
  const FromMeshParams params = from_mesh_params(d, spec_.box.half_extents, part);
  std::unique_ptr<Deformer> fitted;
  FitRecord fit;
  const Source source = cached(
      fit, "from mesh fit", fit_key, session_.counters_.fit,
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
            return mesh_pairs(job_.mesh->file.string(), mesh_, copy.vertices, copy.name, spec_.box);
          } catch (const Error& e) {
            throw Error(job_.where + ".deformer.target: " + e.what());
          }
        }();
        if (pairs.sources.empty())
          throw Error(job_.where +
                      ".deformer.target: no vertex of the mesh lies in the box: nothing to fit");
        std::vector<PointPair> point_pairs(pairs.sources.size());
        for (size_t i = 0; i < point_pairs.size(); ++i)
          point_pairs[i] = {pairs.sources[i], pairs.targets[i]};
        FitRecord r;
        FromMeshFit figures;
        try {
          fitted = make_from_mesh(spec_.box.half_extents, point_pairs, params, &figures,
                                  interrupter_, &r.positions);
        } catch (const Error& e) {
          throw Error(job_.where + ".deformer: " + e.what());
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
      fitted = from_mesh_fitted(spec_.box.half_extents, params, fit.positions, fit.report.pairs,
                                interrupter_);
    } catch (const Error& e) {
      throw Error(job_.where + ": the cached from_mesh fit does not fit the box: " + e.what());
    }
  }
  out_.deformer = std::move(fitted);
  report_.deformer = out_.deformer->describe();
  report_.from_mesh = fit.report;
  StageReport s;
  s.stage = Stage::Fit;
  s.source = source;
  s.resolution = fit.cells;
  s.spacing = (2.0 * spec_.box.half_extents).cwiseQuotient(fit.cells.cast<double>().cwiseMax(1.0));
  s.bytes = value_bytes(fit);
  s.seconds = fit.report.seconds;
  report_.stages.push_back(s);
  const FromMeshReport& fm = fit.report;
  if (fm.torn > 0)
    report_.warnings.push_back(
        {"torn_target", std::to_string(fm.torn) +
                            " vertices the mesh joins are pulled apart by the target (it tears "
                            "the surface there): each is moved to the mean of its copies"});
  if (fm.moved_outside > 0)
    report_.warnings.push_back(
        {"target_outside_box",
         std::to_string(fm.moved_outside) +
             " vertices outside the box move in the target: they are drawn at rest; grow the "
             "box to hold the whole deformation"});
}

void BoxBake::simulation() {
  const SimulationParams params = simulation_params(spec_.deformer);
  auto key_for = [&](const DeformerSpec& d) {
    return (Key() << "simulation\nmesh" << job_.mesh->hash << "\n"
                  << box_key(spec_.box) << "\nimplicit"
                  << (sdf_key_.empty() ? "depth cube " + std::to_string(implicit_.resolution)
                                       : sdf_key_)
                  << "\n"
                  << deformer_key(d))
        .str();
  };
  simulation_key_ = key_for(spec_.deformer);
  // Only the margin's band matters.
  const double cell = 2.0 * spec_.box.half_extents.maxCoeff() / params.resolution;
  const double bound = 2.0 * std::max(params.margin, std::sqrt(3.0) * cell) + cell;
  const TriangleBvh bvh(mesh_);
  const SimulationInput part = part_distance(bound, bvh);
  std::vector<std::string> sim_notes;
  const auto started = std::chrono::steady_clock::now();
  Simulation sim = [&] {
    try {
      return Simulation(params, spec_.box.half_extents, part, &sim_notes, interrupter_);
    } catch (const Error& e) {
      throw Error(job_.where + ".deformer." + e.what());
    }
  }();
  SimulationRecord state;
  const Source source = cached(
      state, "simulation", simulation_key_, session_.counters_.simulation,
      [&] {
        // Every keep_every-th state is stored under its own step count (memory and disk), so
        // a sequence of bakes at those counts runs the simulation once.
        auto keep_state = [&](long step, const std::vector<Eigen::Vector3d>& positions) {
          if (step == params.steps) return;  // the stage stores it
          DeformerSpec at = spec_.deformer;
          at.sim_steps = static_cast<double>(step);
          SimulationRecord r;
          r.positions = positions;
          r.steps = step;
          r.cg_iterations = sim.stats().cg_iterations;
          r.cg_capped = sim.stats().cg_capped;
          r.seconds = seconds_since(started);
          const std::string key = key_for(at);
          session_.keep(key, std::make_shared<const SimulationRecord>(r), value_bytes(r));
          if (session_.disk_) session_.disk_->put("simulation", key, save_simulation(r), nullptr);
        };
        try {
          sim.run(job_.keep_every, job_.keep_every > 0 ? Simulation::Keep(keep_state) : nullptr,
                  interrupter_);
        } catch (const Error& e) {
          throw Error(job_.where + ".deformer: " + e.what());
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
    throw Error(job_.where + ": the cached simulation state does not fit the body");
  out_.deformer = sim.deformer(state.positions);
  for (std::string& n : sim_notes) report_.warnings.push_back({"deformer_note", std::move(n)});
  report_.deformer = out_.deformer->describe();
  const SimulationStats& st = sim.stats();
  report_.simulation =
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
  report_.stages.push_back(s);
  if (state.cg_capped > 0)
    report_.warnings.push_back(
        {"solver_cap", std::to_string(state.cg_capped) + " of " + std::to_string(state.steps) +
                           " implicit Euler solves stopped at the CG iteration cap above their "
                           "tolerance: the state is less accurate than asked (lower dt)"});
}

// D's layout and its cache key: the region it covers (a cylindrical texture, library/cylindrical.h,
// covers the deformed box grown by two voxels), and for "auto" its target error and budget.
void BoxBake::deformation_layout() {
  tex_.moves_nothing = out_.deformer->moves_nothing();
  report_.moves_nothing = tex_.moves_nothing;
  automatic_ = !tex_.moves_nothing && spec_.deformation_resolution == kAutoResolution;
  target_ = kAutoErrorVoxels * voxel_;
  const MappingSpec& mapping = spec_.mapping;
  cylindrical_d_ = mapping.cylindrical && !tex_.moves_nothing;
  if (mapping.cylindrical && job_.centre_on_lower_faces)
    throw Error(job_.where +
                ".mapping: a cylindrical texture is not read through a texture map M "
                "(the animation re-bakes every frame instead)");
  cylinder_region_ = deformed_bounds(*out_.deformer, spec_.box.half_extents, 2.0 * voxel_);
  if (tex_.moves_nothing)
    cylinder_region_.extend(Eigen::AlignedBox3d(
        -spec_.box.half_extents - Eigen::Vector3d::Constant(kCapVoxels * voxel_),
        spec_.box.half_extents + Eigen::Vector3d::Constant(kCapVoxels * voxel_)));
  domain_ = cylindrical_domain(cylinder_region_, mapping.axis, spec_.box.half_extents);
  Key mapping_key;
  if (mapping.cylindrical)
    mapping_key << "cylindrical about" << mapping.axis << "angle texels" << mapping.angle_texels
                << "floor" << kAutoCylindricalFloor[0] << kAutoCylindricalFloor[1]
                << kAutoCylindricalFloor[2] << "domain" << domain_.radius << domain_.low
                << domain_.high << "faces" << domain_.faces << domain_.face_low
                << domain_.face_high;
  mapping_key_ = mapping_key.str();
  const auto budget = static_cast<std::uint64_t>(spec_.deformation_max_mib * double(1 << 20));
  Key layout;
  if (automatic_)
    layout << "auto, error" << target_ << "budget" << double(budget) << "floor"
           << kAutoFloorResolution;
  else
    layout << (tex_.moves_nothing ? 2 : spec_.deformation_resolution);
  def_key_ = (Key() << "deformation\n"
                    << deformer_key(spec_) << simulation_key_ << "\nresolution" << layout.str()
                    << (job_.centre_on_lower_faces ? "centred on the lower faces" : "")
                    << "residual tolerance" << kResidualVoxels * voxel_
                    << (cylindrical_d_ ? mapping_key_ : std::string()))
                 .str();
}

// D and the figures measured on it: its error, Lipschitz bound, inverse residual and folds. A
// deformer that moves nothing needs no displacement: a minimal texture keeps the shader's
// bindings uniform, and rays are cast over the box grown by kCapVoxels voxels.
void BoxBake::deformation() {
  deformation_layout();
  const int resolution = tex_.moves_nothing ? 2 : spec_.deformation_resolution;
  const auto budget = static_cast<std::uint64_t>(spec_.deformation_max_mib * double(1 << 20));
  const bool centred = job_.centre_on_lower_faces && !tex_.moves_nothing;
  const MappingSpec& mapping = spec_.mapping;
  const Source source = cached(
      record_, "deformation", def_key_, session_.counters_.deformation,
      [&] {
        DeformationRecord r;
        const Deformer& d = *out_.deformer;
        const Eigen::Vector3d& h = spec_.box.half_extents;
        if (cylindrical_d_) {
          if (automatic_) {
            AutoDeformation a = bake_cylindrical_deformation_auto(
                d, h, mapping.axis, domain_, target_, budget, cylindrical_floor(), interrupter_);
            r.texture = std::move(a.texture);
            r.texture_error = a.error;
            r.choice = a.choice;
          } else {
            const Eigen::Vector3i counts(mapping.angle_texels, resolution, resolution);
            r.texture =
                bake_cylindrical_deformation(d, mapping.axis, domain_, counts, interrupter_);
            r.texture_error =
                cylindrical_deformation_error(d, h, r.texture, mapping.axis, interrupter_);
          }
          // No Lipschitz bound is measured: cylindrical textures never skip (skipping_pays).
          r.lipschitz = std::numeric_limits<double>::infinity();
          r.residual = measure_cylindrical_residual(d, h, r.texture, mapping.axis,
                                                    kResidualVoxels * voxel_, interrupter_);
          r.folds = measure_folds(d, h, 64, interrupter_);
          return r;
        }
        if (automatic_) {
          AutoDeformation a = bake_deformation_auto(d, h, target_, budget, kAutoFloorResolution,
                                                    centred, interrupter_);
          r.texture = std::move(a.texture);
          r.texture_error = a.error;
          r.choice = a.choice;
        } else {
          r.texture = bake_deformation(d, h, resolution, centred, interrupter_);
          if (!tex_.moves_nothing)
            r.texture_error = deformation_texture_error(d, r.texture, 2, interrupter_);
        }
        if (!tex_.moves_nothing) {
          r.lipschitz = displacement_lipschitz(d, r.texture, interrupter_);
          r.residual =
              measure_inverse_residual(d, r.texture, kResidualVoxels * voxel_, interrupter_);
          if (const auto* added = dynamic_cast<const AddedDetail*>(&d))
            r.added_detail = measure_added_detail(*added, h, r.texture, interrupter_);
        }
        r.folds = measure_folds(d, h, 64, interrupter_);
        return r;
      },
      save_deformation, load_deformation);
  tex_.deformation = std::move(record_.texture);
  report_.stages.push_back(
      grid_stage(Stage::Deformation, tex_.deformation.grid, tex_.deformation.bake_seconds, source));
  if (tex_.moves_nothing) {
    const Eigen::Vector3d pad = Eigen::Vector3d::Constant(kCapVoxels * voxel_);
    tex_.region = Eigen::AlignedBox3d(-spec_.box.half_extents - pad, spec_.box.half_extents + pad);
    if (!tex_.uses_depth_cube)  // within the distance grid
      tex_.region = tex_.region.intersection(
          Eigen::AlignedBox3d(tex_.sdf.grid.origin, tex_.sdf.grid.upper()));
    tex_.lipschitz = 1.0;
  } else if (cylindrical_d_) {
    tex_.region = cylinder_region_;
    tex_.lipschitz = record_.lipschitz;
  } else {
    tex_.region = Eigen::AlignedBox3d(tex_.deformation.grid.origin, tex_.deformation.grid.upper());
    tex_.lipschitz = record_.lipschitz;
  }
  if (mapping.cylindrical) tex_.cylindrical_axis = mapping.axis;
  report_.lipschitz = tex_.lipschitz;
}

// A (the cut's alpha map) over the ray-cast region, and its measured error.
void BoxBake::alpha() {
  tex_.has_cut = true;
  tex_.cut_mode = spec_.cut_mode;
  tex_.shell_thickness = spec_.shell_thickness;
  const Deformer& deformer = *out_.deformer;
  const MappingSpec& mapping = spec_.mapping;
  const bool auto_alpha = spec_.alpha_resolution == kAutoResolution;
  const auto alpha_budget = static_cast<std::uint64_t>(spec_.alpha_max_mib * double(1 << 20));
  const double band = kAlphaBandVoxels * voxel_;
  Key alpha_layout;
  if (auto_alpha)
    alpha_layout << "auto, error" << target_ << "band" << band << "budget" << double(alpha_budget)
                 << "floor" << kAutoAlphaFloorResolution;
  else
    alpha_layout << spec_.alpha_resolution;
  const Eigen::AlignedBox3d& region = tex_.region;
  const std::string alpha_key =
      (Key() << "alpha\n"
             << deformer_key(spec_) << "\nregion" << region.min().x() << region.min().y()
             << region.min().z() << region.max().x() << region.max().y() << region.max().z()
             << "\nresolution" << alpha_layout.str() << mapping_key_)
          .str();
  AlphaRecord alpha;
  const Source source = cached(
      alpha, "alpha", alpha_key, session_.counters_.alpha,
      [&] {
        AlphaRecord r;
        if (mapping.cylindrical) {
          if (auto_alpha) {
            AutoAlpha a =
                bake_cylindrical_alpha_auto(deformer, mapping.axis, domain_, target_, band,
                                            alpha_budget, cylindrical_floor(), interrupter_);
            r.map = std::move(a.map);
            r.error = a.error;
            r.choice = a.choice;
          } else {
            const Eigen::Vector3i counts(mapping.angle_texels, spec_.alpha_resolution,
                                         spec_.alpha_resolution);
            r.map = bake_cylindrical_alpha(deformer, mapping.axis, domain_, counts, interrupter_);
            r.error = cylindrical_alpha_error(deformer, r.map, mapping.axis, band, interrupter_);
          }
          return r;
        }
        if (auto_alpha) {
          AutoAlpha a = bake_alpha_auto(deformer, region, target_, band, alpha_budget,
                                        kAutoAlphaFloorResolution, interrupter_);
          r.map = std::move(a.map);
          r.error = a.error;
          r.choice = a.choice;
        } else {
          r.map = bake_alpha(deformer, region, spec_.alpha_resolution, interrupter_);
          r.error = alpha_map_error(deformer, r.map, band, 1, interrupter_);
        }
        return r;
      },
      save_alpha, load_alpha);
  tex_.alpha = std::move(alpha.map);
  report_.alpha_error = alpha.error;
  report_.alpha_choice = alpha.choice;
  report_.stages.push_back(
      grid_stage(Stage::Alpha, tex_.alpha.grid, tex_.alpha.bake_seconds, source));
}

// What D's figures say: the inverse residual, a texture coarser than a voxel, folds.
void BoxBake::texture_warnings() {
  if (!tex_.moves_nothing) {
    report_.texture_error = record_.texture_error;
    report_.deformation_choice = record_.choice;
    report_.residual = record_.residual;
    const InverseResidual& res = record_.residual;
    const bool added_detail = dynamic_cast<const AddedDetail*>(out_.deformer.get()) != nullptr;
    if (added_detail) report_.added_detail = record_.added_detail;
    if (res.over_tolerance > 0 && !added_detail) {
      std::string w = "the deformation texture does not invert the deformation at " +
                      std::to_string(res.over_tolerance) + " of " + std::to_string(res.texels) +
                      " texels (residual up to " + fmt("%.3g", res.max) + " units, over " +
                      fmt("%g", kResidualVoxels) + " voxel";
      if (res.folded)
        w += "; " + std::to_string(res.folded) + " texels lie where the deformation folds";
      w += "): those points have no preimage or Newton's method did not find it";
      report_.warnings.push_back({"inverse_residual", w});
    }
    const double voxels = report_.texture_error_voxels();
    const std::string advice =
        automatic_ ? "raise deformation.max_mib (now " + fmt("%g", spec_.deformation_max_mib) +
                         "; the automatic layout stopped " +
                         (record_.choice.budget_bound
                              ? std::string("at that budget")
                              : "after " + std::to_string(record_.choice.bakes) + " bakes") +
                         ")"
                   : "raise deformation.resolution (now " +
                         std::to_string(spec_.deformation_resolution) + ") or set it to \"auto\"";
    if (voxels > 1.0)
      report_.warnings.push_back(
          {"texture_coarse", "the deformation texture misplaces points by up to " +
                                 fmt("%.3g", report_.texture_error) + " units (" +
                                 fmt("%.2g", voxels) +
                                 " voxels of the distance grid) between its texels: " + advice});
  }
  report_.folds = record_.folds;
  if (report_.folds.folds())
    report_.warnings.push_back(
        {"folds", "the deformation folds space in " + fmt("%.3g", report_.folds.folded_volume) +
                      " cubic units (" +
                      fmt("%.2f", 100.0 * report_.folds.folded_volume / report_.folds.box_volume) +
                      " % of the box, where det J <= 0); raywarp renders the non-folded branch "
                      "there"});
}

// What the mesh and the box say: an empty box, torn faces, open edges, rays too short.
void BoxBake::mesh_warnings() {
  if (!box_holds_mesh(mesh_, spec_.box))
    report_.warnings.push_back(
        {"empty_box",
         "the box holds no part of the mesh (no triangle meets it, and it is not "
         "inside the mesh): it deforms nothing; check its centre and size against "
         "the mesh's bounds"});
  for (const auto& face : torn_faces(mesh_, spec_.box, *out_.deformer))
    report_.warnings.push_back(
        {"torn_face", "the mesh crosses box face " + face +
                          ", where the deformation is not the identity: the surface tears there"});
  if (const OpenEdges open = open_edges_in_box(mesh_, spec_.box); open.any()) {
    std::string w = "the mesh is open or non-manifold inside the box (" +
                    std::to_string(open.boundary) + " boundary and " +
                    std::to_string(open.nonmanifold) +
                    " non-manifold edges): its inside there is taken from the generalised "
                    "winding number";
    if (tex_.uses_depth_cube)
      w += ", and a depth cube draws no sheet that has no inside of its own";
    else if (tex_.sdf.sheet_faces > 0)
      w += ", and the " + std::to_string(tex_.sdf.sheet_faces) +
           " faces with no inside of their own (sheets, cards, fins) are drawn as shells " +
           fmt("%.3g", 2.0 * tex_.sdf.sheet_half_thickness) + " units (" +
           fmt("%g", 2.0 * kSheetHalfVoxels) + " voxels) thick";
    report_.warnings.push_back({"open_mesh", w});
  }
  const double ray_length = tex_.region.diagonal().norm();
  const double reach = job_.max_steps * job_.step_voxels * voxel_;
  if (reach < ray_length)
    report_.warnings.push_back(
        {"max_steps_short", "render.max_steps = " + std::to_string(job_.max_steps) + " covers " +
                                fmt("%.3g", reach) + " units of a ray, less than the " +
                                fmt("%.3g", ray_length) +
                                " across the deformed box: long rays stop early and miss"});
}

// The bricks' bounds for bounded tracing (after the 16-bit rounding, which they bound).
void BoxBake::step_bounds() {
  const std::string bounds_key =
      (Key() << "step bounds\n"
             << sdf_key_ << "\n"
             << def_key_ << (job_.texture_bits == 16 ? "16-bit" : "32-bit"))
          .str();
  const Source source = cached(
      tex_.step_bounds, "bounds", bounds_key, session_.counters_.step_bounds,
      [&] { return bake_step_bounds(tex_.sdf, tex_.deformation, 8, interrupter_); },
      save_step_bounds, load_step_bounds);
  const StepBounds& sb = tex_.step_bounds;
  StageReport s = grid_stage(Stage::StepBounds, sb.bricks, 0.0, source);
  s.bytes += grid_bytes(sb.sdf_bricks);
  report_.stages.push_back(s);
  report_.brick_cells = sb.brick_cells;
  auto range = [](const Grid3<float>& g, double& lo, double& hi) {
    const auto [a, b] = std::minmax_element(g.data.begin(), g.data.end());
    lo = *a;
    hi = *b;
  };
  range(sb.sdf_bricks, report_.sdf_bound_min, report_.sdf_bound_max);
  range(sb.bricks, report_.d_bound_min, report_.d_bound_max);
  report_.sdf_lipschitz = sb.sdf_lipschitz;
}

BakedBox BakeSession::bake(const BakeJob& job, Interrupter* interrupter) {
  if (!job.mesh) throw Error(job.where + ": no mesh");
  return BoxBake(*this, job, interrupter).run();
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
