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
#include "library/camera.h"
#include "library/textures.h"

namespace raywarp {

// A control point of the "control_points" deformer: where a point of the undeformed mesh goes, in
// the box's local frame (the scene gives object coordinates; load_scene converts them).
struct PointPair {
  Eigen::Vector3d source = Eigen::Vector3d::Zero();
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
};

struct DeformerSpec {
  std::string type;      // "twist" | "bend" | "peel" | "incision" | "box_cut" | "control_points"
  int axis = 1;          // 0 = x, 1 = y, 2 = z (twist, bend: the axis; peel: the curl axis;
                         // incision: the normal of the cut plane)
  double angle_deg = 0;  // twist: any; bend: (-360, 360); peel: (0, 180]
  // peel and incision: the face the cut enters through, e.g. "+y" (axis, side).
  int from_axis = 1;
  int from_side = 1;
  double thickness = 0;  // peel: layer thickness, (0, 2 h_from)
  double radius = 0;     // peel: curl radius, > 0
  double hinge = 0;      // peel: where the flap starts along the peel direction, [-h_a, h_a)
  double depth = 0;      // incision: how far the cut reaches from its face, (0, 2 h_from]
  double opening = 0;    // incision: width of the gap at the face, (0, 2 h_normal)
  // box_cut: the removed sub-box as fractions of the box along its local axes, 0 = min face,
  // 1 = max face (default the whole box), and an optional wedge about an axis through the box
  // centre, from wedge_from_deg over wedge_angle_deg (0 = no wedge).
  Eigen::Vector3d sub_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d sub_max = Eigen::Vector3d::Ones();
  int wedge_axis = 1;
  double wedge_from_deg = 0;
  double wedge_angle_deg = 0;  // (0, 180] when given
  // control_points: the pairs, the radius of influence of each point (object units; 0 = every
  // point acts on the whole box) and the faces held fixed, in the order -x, +x, -y, +y, -z, +z.
  std::vector<PointPair> points;
  double influence_radius = 0;
  std::array<bool, 6> pinned{};
};

struct ImplicitSpec {
  std::string type = "sdf";    // "sdf" (distance grid) | "depth_cube" (library/depth_cube.h)
  int resolution = 128;        // voxels (texels) along the box's longest side, [8, 1024]
                               // ([8, 4096] for a depth cube)
  double band_voxels = 3.0;    // narrow-band half width, [1, 32] (sdf only)
  double margin_voxels = 2.0;  // grid margin around the box, [0, 64] (sdf only)
};

struct BoxSpec {
  Box box;
  // The box's deformers in the order they apply: `deformer` first, then each of `then` (the
  // scene's "deformer": [a, b, c] gives deformer = a, then = {b, c}). Only continuous deformers
  // (twist, bend, control_points) compose; a cut stands alone.
  DeformerSpec deformer;
  std::vector<DeformerSpec> then;
  ImplicitSpec implicit;
  int deformation_resolution = 96;  // texels of D along the longest side of F(box), [4, 1024]
  // Cuts only (peel, incision, box_cut):
  CutMode cut_mode = CutMode::Solid;
  double shell_thickness = 0;  // thick_shell: tau in object units, > 0 (required for it)
  int alpha_resolution = 64;   // texels of A along the longest side, [4, 1024]
};

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
  // shrunk by fine_factor where |value| < threshold_voxels voxels), "jacobian" (eq. 4:
  // step / |(I + J_D) v|, clamped to [step / 16, 4 step]), "bounded" (sphere tracing of
  // g = f(p' + D(p')) with steps bounded by Lipschitz constants per brick of D).
  // The default, threshold at 4 voxels with 1/8 of that (0.5 voxel) within 2 voxels of the
  // surface, or a neighbour of it, matched linear at 0.5 voxel in every error figure of
  // `raywarp study` on the shipped scenes at 1.3-3.9x less frame time (docs/study/report.md).
  std::string sampling = "threshold";
  double threshold_voxels = 2.0;  // (0, 64]
  double fine_factor = 0.125;     // (0, 1]
  // "bounded": sphere tracing with Lipschitz-bounded steps (see StepBounds); a sample where
  // g > -hit_epsilon_voxels voxels counts as the hit. Continuous deformations only.
  double hit_epsilon_voxels = 0.02;  // (0, 1]
  int texture_bits = 32;             // 32 or 16: float precision of the textures on the GPU
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
