// The scene file (docs/scene.md documents every field). Loading validates everything; an error
// names the file, the field, the value and what is allowed, and throws Error.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/box.h"
#include "deformers/registry.h"
#include "library/camera.h"
#include "library/preintegration.h"
#include "library/sampling.h"
#include "library/textures.h"

namespace raywarp {

// "resolution": "auto" of the implicit surface, the deformation texture and the alpha map.
constexpr int kAutoResolution = 0;

// The implicit's automatic resolution: the feature size of the part of the mesh in the box
// (probe_thickness, library/thickness.h: the kFeatureQuantile quantile of its limbs' thickness,
// twice a sheet's) spans at least kFeatureVoxels voxels, from kAutoImplicitFloorResolution up,
// within ImplicitSpec::max_mib (choose_implicit_resolution, library/implicit.h).
constexpr int kAutoImplicitFloorResolution = 128;
// With sheets in the box (library/sheets.h) the automatic distance grid takes at least this
// resolution, within max_mib. A sheet is drawn as a shell about a voxel thick, and its outline
// is off by about 0.13 voxel (the twisted card of tests/sheets_test.cpp at 128, 256 and 384): for
// half a pixel in a 1920x1080 view with the box's longest side across its 1080 rows, a voxel may
// span 0.5 / 0.13 = 3.8 pixels, 284 voxels along that side, rounded up to a multiple of 8.
constexpr int kSheetAutoResolution = 288;
// ... when the sheets hold at least this share of the area of the faces in the box.
constexpr double kSheetAreaShare = 0.01;
constexpr double kFeatureVoxels = 5.0;
constexpr double kFeatureQuantile = 0.05;

struct ImplicitSpec {
  std::string type = "sdf";  // "sdf" (distance grid) | "depth_cube" (library/depth_cube.h)
  // Voxels (texels) along the box's longest side, [8, 1024] ([8, 4096] for a depth cube), or
  // kAutoResolution ("auto", the default).
  int resolution = kAutoResolution;
  double max_mib = 48;  // the automatic resolution's budget, MiB, [1, 1024]
  // Narrow-band half width, [1, 32] (sdf only): as wide as the threshold method's coarse step
  // (step_voxels 4), which goes no further than |f| (RenderSettings::sampling).
  double band_voxels = 4.0;
  double margin_voxels = 2.0;  // grid margin around the box, [0, 64] (sdf only)
};

// The automatic layouts of the deformation texture start from, and never go below, the cubic
// layout of this many texels along the longest side (the fixed default before layouts were
// automatic).
constexpr int kAutoFloorResolution = 96;
// The error they aim at: this many voxels of the implicit (distance grid or depth maps).
constexpr double kAutoErrorVoxels = 0.5;
// The alpha map's floor, and the band around the cut face (implicit voxels) where its error counts.
constexpr int kAutoAlphaFloorResolution = 64;
constexpr double kAlphaBandVoxels = 2.0;

// How a box's deformation texture and alpha map are stored ("mapping"): over (x, y, z), or over
// (angle, radius, height) about the box's axis `axis` through its centre (library/cylindrical.h).
// With an explicit resolution n (deformation or alpha), a cylindrical texture has n texels along
// the radius and along the height and `angle_texels` around; "auto" chooses all three counts
// from the floor kAutoCylindricalFloor.
struct MappingSpec {
  bool cylindrical = false;
  int axis = 1;           // 0 = x, 1 = y, 2 = z
  int angle_texels = 16;  // [2, 1024]
};
constexpr int kAutoCylindricalFloor[3] = {8, 32, 32};  // angle, radius, height

struct BoxSpec {
  Box box;
  // The box's deformers in the order they apply: `deformer` first, then each of `then` (the
  // scene's "deformer": [a, b, c] gives deformer = a, then = {b, c}). Only continuous deformers
  // (twist, bend, control_points) compose; a cut stands alone.
  DeformerSpec deformer;
  std::vector<DeformerSpec> then;
  ImplicitSpec implicit;
  // Texels of D along the longest side of F(box), [4, 1024] (cubic texels), or kAutoResolution
  // ("auto", the default): counts per axis chosen so that D's interpolation error is at most
  // kAutoErrorVoxels voxels of the implicit, from the cubic layout of kAutoFloorResolution up,
  // within deformation_max_mib (library/deformation_bake.h, bake_deformation_auto).
  int deformation_resolution = kAutoResolution;
  double deformation_max_mib = 64;  // the automatic layout's budget, MiB, [1, 1024]
  // Cuts only (peel, incision, box_cut):
  CutMode cut_mode = CutMode::Solid;
  double shell_thickness = 0;  // thick_shell: tau in object units, > 0 (required for it)
  // Texels of A along the longest side, [4, 1024], or kAutoResolution ("auto", the default):
  // counts per axis for an error of at most kAutoErrorVoxels where A places the cut face (within
  // kAlphaBandVoxels of it), from the cubic layout of kAutoAlphaFloorResolution up, within
  // alpha_max_mib (bake_alpha_auto).
  int alpha_resolution = kAutoResolution;
  double alpha_max_mib = 16;  // [1, 1024]
  MappingSpec mapping;
};

// How the second image-space route shows a simulation box (render.route "tets"): the body's
// tetrahedra in the simulated state, walked by the tetrahedral ray caster (library/tet_body.h,
// docs/tet_render.md).
struct TetDisplaySpec {
  // "surface": the first crossing of f (the mesh part's signed distance, > 0 inside, carried on
  // the nodes); "volume": the scalar through the pre-integrated transfer function.
  std::string mode = "surface";
  // Each lattice cell split into refine^3 cells before the Kuhn split, [1, 8], or
  // kAutoResolution ("auto", the default): the smallest split whose cells are at most
  // kTetAutoCellVoxels voxels of the implicit on their longest side, within kMaxRenderTets.
  int refine = kAutoResolution;
  std::string scalar = "f";  // volume: "f" (object units) or "strain" (largest |stretch - 1|)
  // volume: the transfer function over the scalar; none: default_transfer_function over the
  // state's range of the scalar.
  std::optional<TransferFunction> transfer;
  int scalar_samples = 128;  // the pre-integration table: N along s_front and s_back, [2, 512]
  int length_samples = 64;   // M along the length, [2, 512]
};
constexpr double kTetAutoCellVoxels = 2.0;
constexpr long kMaxRenderTets = 4000000;

// The step of linear and jacobian sampling when the scene gives none, voxels.
constexpr double kFineStepVoxels = 0.5;

struct RenderSettings {
  int width = 512, height = 512;  // [1, 8192]
  // Step in voxels of the distance grid, (0, 8]: threshold's coarse step; linear's and jacobian's
  // step (kFineStepVoxels when the scene picks those methods and gives no step).
  double step_voxels = 4.0;
  int max_steps = 1024;                            // bound on the linear search, [1, 100000]
  int refine_steps = 8;                            // binary refinement steps, [0, 64]
  Eigen::Vector3d background{1, 1, 1};             // linear RGB in [0, 1]
  Eigen::Vector3d colour{0.8, 0.62, 0.45};         // surface albedo, linear RGB in [0, 1]
  Eigen::Vector3d cut_colour{0.75, 0.18, 0.16};    // solid cut faces, linear RGB
  Eigen::Vector3d inside_colour{0.3, 0.42, 0.62};  // the inside of a shell (back faces)
  bool skipping = true;  // empty-space skipping (cut region and far from the surface)
  // Linear-search step rule: "linear" (fixed step), "threshold" (Hadwiger et al. 2005: a step
  // shrunk by fine_factor where |value| < threshold_voxels voxels, and no longer than |value|
  // beyond that), "jacobian" (eq. 4:
  // step / |(I + J_D) v|, clamped to [step / 16, 4 step]), "bounded" (sphere tracing of
  // g = f(p' + D(p')) with steps bounded by Lipschitz constants per brick of D).
  // The default, threshold at 4 voxels with 1/8 of that (0.5 voxel) within 2 voxels of the
  // surface, or a neighbour of it, matched linear at 0.5 voxel in every error figure of
  // `raywarp study` on the shipped scenes at 1.3-3.9x less frame time (docs/study/report.md).
  Sampling sampling = Sampling::Threshold;
  double threshold_voxels = 2.0;  // (0, 64]
  double fine_factor = 0.125;     // (0, 1]
  // "bounded": sphere tracing with Lipschitz-bounded steps (see StepBounds); a sample where
  // g > -hit_epsilon_voxels voxels counts as the hit. Continuous deformations only.
  double hit_epsilon_voxels = 0.02;  // (0, 1]
  int texture_bits = 32;             // 32 or 16: float precision of the textures on the GPU
  // How simulation boxes are shown: "texture" (the deformation texture, ray cast; every
  // deformer) or "tets" (the body's tetrahedra walked by the tetrahedral ray caster; scenes
  // whose boxes are all simulations).
  std::string route = "texture";
  TetDisplaySpec tets;
};

// The textures of all boxes of a scene together must fit in this many bytes; load_scene checks
// it before anything is allocated, and the bakes are given the same budget.
constexpr std::uint64_t kMemoryBudgetBytes = std::uint64_t(4) << 30;

struct Scene {
  std::filesystem::path file;  // the scene file itself
  std::filesystem::path mesh;  // resolved against the scene file's folder
  std::vector<BoxSpec> boxes;
  std::optional<Camera> camera;
  RenderSettings render;
};

Scene load_scene(const std::filesystem::path& path);
// The scene file parsed, not yet validated (Error naming the file when it is not JSON).
nlohmann::json read_scene_document(const std::filesystem::path& path);
// The same from a parsed document; `path` is where it came from (errors name it, and relative
// paths in it resolve against its folder).
Scene load_scene_json(const nlohmann::json& document, const std::filesystem::path& path);
// The image size by precedence: command line (when > 0), else the camera's, else `render`.
Eigen::Vector2i image_size(const Scene& scene, const Camera& camera, int cli_width, int cli_height);

}  // namespace raywarp
