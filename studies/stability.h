// The stability study behind `raywarp study --stability`: every scene of a set of extreme cases
// (examples/extreme/) baked, rendered and measured against the exact ground truth, then written
// up as one markdown table (docs/stability.md). It answers, per case: does anything turn into a
// NaN or an infinity, how far is the image from the exact deformed surface, how long does a frame
// take, and does raywarp warn where it is wrong.
#pragma once
#include <cmath>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace raywarp {

// The error thresholds a case must meet to pass: the silhouette's IoU against the exact ground
// truth, and the fraction of pixels covered in both whose depths differ by more than 1 % of the
// ground truth's bounding diagonal.
constexpr double kStabilityMinIoU = 0.98;
constexpr double kStabilityMaxFractionOver = 0.02;

struct StabilityCase {
  std::filesystem::path scene;  // the scene file
  std::string name;             // file stem
  // What the case stresses, from the table in the README.md beside the scene (a row whose first
  // cell lists `file.json` names); "" when no row names it.
  std::string stresses;
  bool textures_finite = false, image_finite = false;
  long nonfinite_pixels = 0;  // the most in any frame, warm-up included
  // Against the exact ground truth, e.g. "IoU 0.9981, 0.12 % over 1 % of diag, mean depth err
  // 0.031 % of diag", or why there is none ("no exact ground truth (a cut)").
  std::string error;
  double iou = NAN, fraction_over = NAN;
  double mean_depth_error = NAN;  // object units, over pixels covered in both
  double frame_ms = 0;            // median of the timed frames (after one warm-up frame)
  double worst_frame_ms = 0;      // slowest timed frame
  // BakedBox::warnings of every box ("box i: " in front when there are several), and the
  // pipeline's log lines that say "warning" and are not one of those.
  std::vector<std::string> warnings;
  // "pass": finite, error within the thresholds (or no exact ground truth) and no warning;
  // "warns": finite and raywarp warned; "fails": a NaN or infinity, an error past the thresholds
  // with no warning to explain it, or a failure while rendering; "rejected": raywarp refused the
  // scene with an error message while loading or baking it.
  std::string verdict;
  // The message when the scene could not be loaded, baked or rendered; "error: ..." for raywarp's
  // own messages (a clean rejection while loading or baking).
  std::string failure;
};

// Loads, bakes, renders at size x size and measures each scene in turn; a scene raywarp rejects
// is recorded as such and the rest still run. Frame times: one warm-up frame (shader compilation,
// texture upload), then the median and the worst of `frames` frames. Writes one progress line per
// case to `progress` ("[3/14] bend_folds: warns, ..."). Needs a current OpenGL context.
std::vector<StabilityCase> run_stability(const std::vector<std::filesystem::path>& scenes, int size,
                                         int frames, std::ostream& progress);

// Writes the markdown report to `out_md` atomically: how the numbers were taken (image size,
// frames, ground truth, thresholds, `machine`: e.g. the GL context's description), one table row
// per case, and a count of the verdicts. Throws Error when the file cannot be written.
void write_stability_report(const std::vector<StabilityCase>& cases,
                            const std::filesystem::path& out_md, int size, int frames,
                            const std::string& machine);

}  // namespace raywarp
