// `raywarp study`: error against frame time. For each scene, every ray-sampling method over a
// sweep of its quality settings (step, refinement, texture resolution and precision, the bounded
// tracer's epsilon and band), and the object-space peer (the forward map applied to the vertices
// of the uniformly subdivided mesh, rasterised: what a vertex shader does), each rendered,
// timed (median of frames after a warm-up) and measured against the scene's exact ground truth.
// Writes DIR/study.csv (one row per run), DIR/pareto.svg (error against ms per scene, one colour
// per method, the Pareto front marked; studies/chart.h) and DIR/report.md (the tables, the
// recommended setting per scene, the speed and memory goals at 512², how the numbers were taken,
// the machine).
#pragma once
#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace raywarp {

struct StudyOptions {
  std::vector<std::filesystem::path> scenes;
  std::filesystem::path out;  // folder for study.csv, pareto.svg, report.md
  int size = 256;             // image side of the sweep
  int frames = 5;             // timed frames per run (median), after one warm-up frame
  int goal_size = 512;        // image side of the speed goals (each scene at its own settings)
  bool quick = false;         // two points per method and no goals (for tests)
  std::string machine;        // the GL context's description, for the report
};

struct StudyRun {
  std::string scene;
  std::string method;    // linear, threshold, jacobian, bounded, object-space
  std::string settings;  // human-readable, e.g. "step 0.5, refine 8, SDF 128, D 96, 32-bit"
  double step_voxels = 0, fine_factor = 0, threshold_voxels = 0, hit_epsilon_voxels = 0;
  int refine_steps = 0, sdf_resolution = 0, deformation_resolution = 0, texture_bits = 32;
  double band_voxels = 0;
  int subdivision_levels = -1;  // object-space only
  double ms = 0;                // median frame time
  double iou = 0, mean_depth_error = 0, max_depth_error = 0;
  double fraction_over = 0;    // of pixels covered in both: depth error > 1 % of the diagonal
  double fraction_missed = 0;  // of the ground truth's covered pixels: not covered by the run
  // Of the pixels the bounded tracer covers (epsilon 0.02, the scene's textures): not covered
  // by the run. Thin features that a step passes over show here. NaN where bounded does not
  // apply (cuts).
  double fraction_missed_vs_bounded = 0;
  size_t memory_bytes = 0;  // textures (image space) or vertex and index buffers (object space)
  long triangles = 0;       // object-space: triangles rasterised
};

// Runs the study (a current OpenGL context is needed), writes the three files, and returns the
// runs. Progress on `progress`, one line per run.
std::vector<StudyRun> run_study(const StudyOptions& options, std::ostream& progress);

// The runs of one scene that no other run beats in both frame time and fraction over (ties on
// both keep the first), ordered by frame time.
std::vector<size_t> study_front(const std::vector<StudyRun>& runs);

// Draws the chart run_study writes (pareto.svg) from a study.csv written earlier, without
// rerunning the study: it reads the scene, method, ms and fraction_over columns (found by name
// in the header). Throws Error naming the file and record if one is missing or not a number.
void write_study_chart_from_csv(const std::filesystem::path& csv, const std::filesystem::path& svg);

}  // namespace raywarp
