// The bake pipeline every front end stands on (the command line, the editor, the exporter):
// per-box bake jobs with progress, cancel, re-bake by stage, and a structured report.
//
//   BakeSession session(&disk_cache);             // one per process (or per editor window)
//   MeshPtr mesh = session.mesh(scene.mesh);      // loaded and hashed once, shared by the jobs
//   BakedBox box = session.bake(make_job(scene, 0, mesh), &interrupter);
//   box.textures -> the renderer; box.report -> sizes, times, errors, warnings as data
//
// A job bakes its stages in order, each read from the session's memory, else from the disk cache,
// else baked (and then stored in both): the implicit surface (distance grid or depth cube), the
// deformation texture D with its figures (Lipschitz bound, interpolation error, inverse residual,
// folds), the alpha map A of a cut, and the step bounds of bounded tracing. Each stage's key names
// every input it reads (library/bake.cpp), so a changed deformer parameter re-bakes D (and A and
// the bounds) but reads the distance grid from memory, and a new camera bakes nothing.
// A cancelled job (Interrupter::cancel) throws Cancelled from its next poll, within 50 ms of work,
// and stores nothing: no cache entry, no file. The library writes no text: the report is data.
#pragma once
#include <cstdint>
#include <filesystem>
#include <list>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/interrupt.h"
#include "deformers/deformer.h"
#include "deformers/simulation.h"
#include "library/added_detail.h"
#include "library/bake_cache.h"
#include "library/deformation_bake.h"
#include "library/implicit.h"
#include "library/mesh.h"
#include "library/scene.h"
#include "library/textures.h"

namespace raywarp {

// A mesh file loaded once: its triangles, statistics and the hash of its bytes (bake cache keys).
struct MeshHandle {
  std::filesystem::path file;
  Mesh mesh;
  MeshStats stats;
  std::string hash;
  double load_seconds = 0.0;
};
using MeshPtr = std::shared_ptr<const MeshHandle>;
// Loads and hashes `file` (Error naming it when unreadable or not a mesh).
MeshPtr load_mesh_handle(const std::filesystem::path& file);

// The stages of a box's bake, in the order they run.
// Fit: a from_mesh deformer's fitted lattice (deformers/from_mesh.h).
enum class Stage { DistanceGrid, DepthCube, Simulation, Deformation, Alpha, StepBounds, Fit };
const char* stage_name(Stage stage);  // "distance grid", "depth cube", ...
// Where a stage's result came from.
enum class Source { Baked, Memory, Disk };
const char* source_name(Source source);  // "baked", "memory", "disk cache"

struct StageReport {
  Stage stage = Stage::DistanceGrid;
  Source source = Source::Baked;
  Eigen::Vector3i resolution = Eigen::Vector3i::Zero();  // texels per axis
  Eigen::Vector3d spacing = Eigen::Vector3d::Zero();     // texel sides per axis, object units
  std::uint64_t bytes = 0;                               // as the GPU stores it (32-bit)
  double seconds = 0.0;                                  // the bake's own time, also when read back
};

// A simulation deformer's body and run (stage Simulation).
struct SimulationReport {
  SimulationStats body;  // lattice, nodes, springs, tets and their quality, pins
  // The lattice at rest and the node positions of the baked state (box frame): what the
  // object-space mappings bind to (library/surface_mapping.h).
  std::shared_ptr<const SimulationBody> lattice;
  std::shared_ptr<const std::vector<Eigen::Vector3d>> state;
  long steps = 0;
  long cg_iterations = 0;  // implicit Euler, over all steps
  long cg_capped = 0;      // implicit Euler solves stopped at the iteration cap
};

// A from_mesh deformer's pairs (library/mesh_pairs.h) and fit.
struct FromMeshReport {
  long pairs = 0;          // mesh vertices in the box, fitted
  long file_vertices = 0;  // the mesh file's vertices, before identical ones were joined
  long mesh_vertices = 0;
  long torn = 0;                                // joined vertices the target pulls apart
  double largest_move = 0;                      // object units
  long moved_outside = 0;                       // vertices outside the box the target moves
  double fit_max_error = 0, fit_rms_error = 0;  // |F(source) - target| over the pairs
  double largest_turn_deg = 0;  // the pairs' largest turn about the line they turn about
  int turn_steps = 1;           // the fit's steps (1: in one go; deformers/from_mesh.h)
  double seconds = 0;           // reading the target and fitting
  int frames = 0;               // of a sequence target (library/mesh_pairs.h); 0: not a sequence
  double frame = 0;             // the frame read, when `frames` > 0
};

// Something a user should know about a bake. `code` is stable (front ends may key on it); the
// message is one sentence with the figures.
struct BakeWarning {
  std::string code;  // deformer_note | inverse_residual | texture_coarse | folds | torn_face |
                     // open_mesh | max_steps_short | cache_store | empty_box | solver_cap |
                     // torn_target | target_outside_box
  std::string message;
};

struct BakeReport {
  std::string deformer;    // Deformer::describe(): "twist about y by 360°"
  std::string parameters;  // describe_spec of each deformer of the box, "; " between
  std::vector<StageReport> stages;
  const StageReport* stage(Stage s) const;  // null when the job had no such stage

  std::optional<SimulationReport> simulation;  // a simulation deformer's body and run
  std::optional<FromMeshReport> from_mesh;     // a from_mesh deformer's pairs
  double voxel = 0.0;  // the implicit's spacing: the unit of steps, seams and the errors below
  ImplicitChoice implicit_choice;  // how an automatic implicit resolution was chosen
  // Distance grid (stage DistanceGrid).
  double band_voxels = 0.0;
  double band_widened_from = 0.0;  // > 0: the scene's band, widened to hold a thick shell
  long active_voxels = 0;
  std::string sign_method;
  // Deformation texture (stage Deformation); none of these for a deformer that moves nothing.
  bool moves_nothing = false;
  double lipschitz = 0.0;      // bound of |I + J_D| of the interpolated texture
  double texture_error = 0.0;  // deformation_texture_error, object units
  double texture_error_voxels() const { return voxel > 0 ? texture_error / voxel : 0.0; }
  ResolutionChoice deformation_choice;  // how an automatic layout was chosen
  // Alpha map (stage Alpha): alpha_map_error within kAlphaBandVoxels of the cut face, object
  // units, and how an automatic layout was chosen.
  double alpha_error = 0.0;
  ResolutionChoice alpha_choice;
  InverseResidual residual;  // measure_inverse_residual at kResidualVoxels voxels
  // A list that adds detail (deformers/composed.h): `residual` is then what adding the inverse
  // displacements instead of composing costs (no inverse_residual warning), and this holds
  // |D - D_exact| (library/added_detail.h).
  std::optional<AddedDetailFigures> added_detail;
  FoldReport folds;
  // Step bounds (stage StepBounds): the ranges of the per-brick bounds.
  int brick_cells = 0;
  double sdf_bound_min = 0, sdf_bound_max = 0, sdf_lipschitz = 0;
  double d_bound_min = 0, d_bound_max = 0;
  bool half_precision = false;  // textures rounded to 16-bit floats
  std::vector<BakeWarning> warnings;
  std::vector<std::string> warning_messages() const;
};

// Residual |F(p' + D(p')) - p'| above which a texel counts as not inverted, in implicit voxels.
constexpr double kResidualVoxels = 0.01;

// Everything one box's bake reads.
struct BakeJob {
  MeshPtr mesh;
  BoxSpec spec;
  std::string where;  // "scene.json: boxes[0]", the prefix of error messages
  // The render settings a bake depends on.
  Sampling sampling = Sampling::Threshold;
  int texture_bits = 32;
  int max_steps = 1024;
  double step_voxels = 4.0;
  // Texel centres of D on the box's lower faces (bake_deformation), for animation by a map M.
  bool centre_on_lower_faces = false;
  // A simulation box's run also keeps every keep_every-th state (0: none) in the session's memory
  // and the disk cache, each under the key of the same box with `steps` set to that step count:
  // bakes of the sequence at steps K, 2K, ... then run the simulation once (`raywarp simulate`).
  long keep_every = 0;
};
BakeJob make_job(const Scene& scene, size_t box_index, MeshPtr mesh,
                 bool centre_on_lower_faces = false);

struct BakedBox {
  BoxTextures textures;
  std::shared_ptr<const Deformer> deformer;
  BakeReport report;
};

class BakeSession {
 public:
  // `disk`: the on-disk cache (null: none). Results are also kept in memory, the least recently
  // used dropped beyond `memory_budget_bytes`.
  explicit BakeSession(BakeCache* disk = nullptr,
                       std::uint64_t memory_budget_bytes = std::uint64_t(1) << 30);
  ~BakeSession();
  BakeSession(const BakeSession&) = delete;
  BakeSession& operator=(const BakeSession&) = delete;

  // The mesh in `file`, loaded and hashed at its first request.
  MeshPtr mesh(const std::filesystem::path& file);
  // Bakes one box. Throws Error (prefixed by job.where) on parameters a deformer refuses or a
  // budget exceeded, Cancelled when `interrupter` is cancelled.
  BakedBox bake(const BakeJob& job, Interrupter* interrupter = nullptr);

  // Stages baked (not read from memory or disk) since the session began.
  struct Counters {
    long distance_grid = 0, depth_cube = 0, simulation = 0, deformation = 0, alpha = 0,
         step_bounds = 0, fit = 0;
    long memory_hits = 0, disk_hits = 0;
    long baked() const {
      return distance_grid + depth_cube + simulation + deformation + alpha + step_bounds + fit;
    }
  };
  const Counters& counters() const { return counters_; }
  std::uint64_t memory_bytes() const { return memory_bytes_; }
  BakeCache* disk() const { return disk_; }

 private:
  friend class BoxBake;  // one box's bake, stage by stage (library/bake.cpp)
  struct Entry;
  std::shared_ptr<const void> find(const std::string& key);
  void keep(const std::string& key, std::shared_ptr<const void> value, std::uint64_t bytes);

  BakeCache* disk_;
  std::uint64_t budget_, memory_bytes_ = 0;
  std::list<Entry> entries_;  // most recently used first
  std::vector<MeshPtr> meshes_;
  Counters counters_;
};

// A whole scene's boxes, baked in one session (the command line and the tests use it).
struct PreparedScene {
  MeshPtr handle;  // the session's mesh, shared with its jobs
  const Mesh& mesh() const { return handle->mesh; }
  const MeshStats& stats() const { return handle->stats; }
  std::vector<BakedBox> boxes;
  int bakes = 0;  // stages baked by this call (not read from memory or the cache)
  std::vector<BoxTextures> textures() const;
};
PreparedScene bake_scene(const Scene& scene, BakeSession& session,
                         bool centre_on_lower_faces = false, Interrupter* interrupter = nullptr);

// The deformer a scene box asks for (its list composed); errors name the scene file and field.
std::shared_ptr<const Deformer> make_deformer(const Scene& scene, size_t box_index,
                                              std::vector<std::string>* warnings = nullptr);
std::shared_ptr<const Deformer> make_box_deformer(const BoxSpec& spec, const std::string& where,
                                                  std::vector<std::string>* warnings = nullptr);
// The cache key of a box's deformers: their every declared parameter and the box's half extents.
std::string deformer_key(const BoxSpec& spec);

// Edges of the mesh used by one triangle (boundary) or by three or more (non-manifold) whose
// midpoints lie in the box: there the mesh has no well-defined inside.
struct OpenEdges {
  long boundary = 0, nonmanifold = 0;
  bool any() const { return boundary + nonmanifold > 0; }
};
OpenEdges open_edges_in_box(const Mesh& mesh, const Box& box);
// Whether any part of the mesh is in the box: a triangle meets it (separating-axis test), or the
// box lies inside the mesh (winding number at its centre > 0.5). A box that holds nothing
// deforms nothing.
bool box_holds_mesh(const Mesh& mesh, const Box& box);
// Faces of the box, as "-x", "+y", ..., that the mesh crosses where F is not the identity.
std::vector<std::string> torn_faces(const Mesh& mesh, const Box& box, const Deformer& deformer);

}  // namespace raywarp
