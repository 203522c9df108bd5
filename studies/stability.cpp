#include "studies/stability.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <ostream>
#include <sstream>
#include <thread>

#include "base/error.h"
#include "base/format.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

namespace raywarp {

namespace {

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Scene stem -> what it stresses, from the markdown table of `readme`: rows whose first cell
// names one or more `file.json`, the second cell saying what those files stress. A README that
// is missing or has no such table gives an empty map: the column is informative, not required.
std::map<std::string, std::string> read_stresses(const std::filesystem::path& readme) {
  std::map<std::string, std::string> out;
  std::ifstream in(readme);
  std::string line;
  while (std::getline(in, line)) {
    line = trim(line);
    if (line.empty() || line[0] != '|') continue;
    std::vector<std::string> cells;
    std::string cell;
    std::istringstream row(line.substr(1));
    while (std::getline(row, cell, '|')) cells.push_back(trim(cell));
    if (cells.size() < 2) continue;
    const std::string& names = cells[0];
    for (size_t open = names.find('`'); open != std::string::npos;
         open = names.find('`', open + 1)) {
      const size_t close = names.find('`', open + 1);
      if (close == std::string::npos) break;
      const std::string file = names.substr(open + 1, close - open - 1);
      const std::string ext = ".json";
      if (file.size() > ext.size() && file.compare(file.size() - ext.size(), ext.size(), ext) == 0)
        out[std::filesystem::path(file).stem().string()] = cells[1];
      open = close;
    }
  }
  return out;
}

bool textures_finite(const PreparedScene& prepared) {
  for (const BakedBox& box : prepared.boxes) {
    for (float v : box.textures.sdf.grid.data)
      if (!std::isfinite(v)) return false;
    for (const DepthMap& m : box.textures.depth_cube.maps)
      for (float v : m.depth)
        if (!std::isfinite(v)) return false;
    for (const Eigen::Vector4f& v : box.textures.deformation.grid.data)
      if (!v.allFinite()) return false;
    for (float v : box.textures.alpha.grid.data)
      if (!std::isfinite(v)) return false;
  }
  return true;
}

// Depth is +inf where empty by convention; NaN or -inf anywhere is a fault.
bool depth_finite(const Image& image) {
  for (float z : image.depth)
    if (std::isnan(z) || z == -std::numeric_limits<float>::infinity()) return false;
  return true;
}

// The box warnings, then the log's warning lines that do not repeat one of them (prepare_scene
// logs each box warning too, as "box i: warning: ...").
std::vector<std::string> collect_warnings(const PreparedScene& prepared, const std::string& log) {
  std::vector<std::string> out, plain;
  const bool several = prepared.boxes.size() > 1;
  for (size_t i = 0; i < prepared.boxes.size(); ++i)
    for (const std::string& w : prepared.boxes[i].report.warning_messages()) {
      plain.push_back(w);
      out.push_back((several ? "box " + std::to_string(i) + ": " : std::string()) + w);
    }
  std::istringstream lines(log);
  std::string line;
  while (std::getline(lines, line)) {
    if (lower(line).find("warning") == std::string::npos) continue;
    bool repeated = false;
    for (const std::string& w : plain) repeated = repeated || line.find(w) != std::string::npos;
    if (!repeated) out.push_back(trim(line));
  }
  return out;
}

void measure(StabilityCase& c, int size, int frames) {
  // Loading and baking: raywarp's own errors here are the scene being refused, which is a valid
  // outcome for an extreme input as long as it is a message and not a crash.
  Scene scene;
  PreparedScene prepared;
  std::ostringstream log;
  try {
    scene = load_scene(c.scene);
    if (!scene.camera) throw Error(c.scene.string() + ": camera: missing");
    scene.render.width = scene.render.height = size;
    prepared = prepare_scene(scene, log);
  } catch (const Error& e) {
    c.verdict = "rejected";
    c.failure = std::string("error: ") + e.what();
    return;
  }
  c.warnings = collect_warnings(prepared, log.str());
  c.textures_finite = textures_finite(prepared);

  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  Image image;
  std::vector<double> ms;
  bool depth_ok = true;
  // The warm-up frame compiles the shaders and uploads the textures: counted for non-finite
  // pixels, not for time.
  for (int i = 0; i <= frames; ++i) {
    gl::FrameStats stats;
    image = renderer.render(*scene.camera, size, size, scene.render, &stats);
    c.nonfinite_pixels = std::max(c.nonfinite_pixels, stats.nonfinite_pixels);
    depth_ok = depth_ok && depth_finite(image);
    if (i > 0) ms.push_back(stats.milliseconds);
  }
  c.image_finite = c.nonfinite_pixels == 0 && depth_ok;
  c.frame_ms = median(ms);
  c.worst_frame_ms = ms.empty() ? 0.0 : *std::max_element(ms.begin(), ms.end());

  // The exact ground truth of box 0: the mesh split at the box faces, subdivided to half a voxel
  // and mapped by the exact forward map. A cut removes material, which a mapped mesh cannot show.
  bool have_truth = true;
  Mesh truth_mesh = prepared.mesh();
  if (!prepared.boxes.empty()) {
    const BakedBox& box = prepared.boxes[0];
    if (box.deformer->has_cut()) {
      have_truth = false;
    } else {
      auto F = [&](const Eigen::Vector3d& p) { return box.deformer->forward(p); };
      truth_mesh = ground_truth_mesh(prepared.mesh(), box.textures.box, F,
                                     0.5 * implicit_spacing(box.textures));
    }
  }
  bool within = true;
  if (have_truth) {
    const Image truth = rasterize(truth_mesh, *scene.camera, size, size, scene.render);
    const double diag = mesh_bounds(truth_mesh).diagonal().norm();
    const ImageComparison cmp = compare_images(image, truth, 0.01 * diag);
    c.iou = cmp.iou;
    c.fraction_over = cmp.fraction_over;
    c.mean_depth_error = cmp.mean_depth_error;
    c.error = "IoU " + fmt("%.4f", cmp.iou) + ", " + fmt("%.2f", 100 * cmp.fraction_over) +
              " % over 1 % of diag, mean depth err " +
              fmt("%.3g", diag > 0 ? 100 * cmp.mean_depth_error / diag : 0.0) + " % of diag";
    within = cmp.iou >= kStabilityMinIoU && cmp.fraction_over <= kStabilityMaxFractionOver;
  } else {
    c.error = "no exact ground truth (a cut)";
  }

  if (!c.textures_finite || !c.image_finite)
    c.verdict = "fails";
  else if (!c.warnings.empty())
    c.verdict = "warns";
  else
    c.verdict = within ? "pass" : "fails";
}

// A table cell: one line, with the column separator escaped.
std::string cell(const std::string& s) {
  std::string out;
  for (char ch : s) {
    if (ch == '|')
      out += "\\|";
    else if (ch == '\n')
      out += ' ';
    else
      out += ch;
  }
  return out;
}

std::string yes_no(bool b) { return b ? "yes" : "**no**"; }

}  // namespace

std::vector<StabilityCase> run_stability(const std::vector<std::filesystem::path>& scenes, int size,
                                         int frames, std::ostream& progress) {
  std::map<std::filesystem::path, std::map<std::string, std::string>> stresses_by_dir;
  std::vector<StabilityCase> out;
  frames = std::max(frames, 1);
  for (size_t i = 0; i < scenes.size(); ++i) {
    StabilityCase c;
    c.scene = scenes[i];
    c.name = scenes[i].stem().string();
    const std::filesystem::path dir = scenes[i].parent_path();
    auto found = stresses_by_dir.find(dir);
    if (found == stresses_by_dir.end())
      found = stresses_by_dir.emplace(dir, read_stresses(dir / "README.md")).first;
    if (auto s = found->second.find(c.name); s != found->second.end()) c.stresses = s->second;

    const auto start = std::chrono::steady_clock::now();
    // Anything other than raywarp's own message while loading or baking (a GL error while
    // rendering, an exception from a library) is a failure of the case, not a rejection; the
    // study goes on with the next scene either way.
    try {
      measure(c, size, frames);
    } catch (const Error& e) {
      c.verdict = "fails";
      c.failure = std::string("error: ") + e.what();
    } catch (const std::exception& e) {
      c.verdict = "fails";
      c.failure = e.what();
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    progress << "[" << i + 1 << "/" << scenes.size() << "] " << c.name << ": " << c.verdict;
    if (!c.failure.empty()) {
      progress << ", " << c.failure;
    } else {
      progress << ", " << c.error << ", frame " << fmt("%.1f", c.frame_ms) << " ms (worst "
               << fmt("%.1f", c.worst_frame_ms) << ")";
      if (!c.warnings.empty()) progress << ", " << c.warnings.size() << " warning(s)";
    }
    progress << " (" << fmt("%.1f", seconds) << " s)\n" << std::flush;
    out.push_back(std::move(c));
  }
  return out;
}

void write_stability_report(const std::vector<StabilityCase>& cases,
                            const std::filesystem::path& out_md, int size, int frames,
                            const std::string& machine) {
  std::ostringstream md;
  md << "# Stability on the extreme cases\n\n"
     << "Written by `raywarp study --stability` (run from the repository root). "
     << "Every scene was loaded, baked and rendered at " << size << " x " << size << " pixels on "
     << (machine.empty() ? "an unnamed OpenGL context" : machine) << " ("
     << std::thread::hardware_concurrency() << " hardware threads).\n\n"
     << "- **Finite**: every texel of the distance grid, the deformation texture and the alpha "
        "map, and every pixel of the colour and depth images, holds no NaN or infinity (empty "
        "pixels have depth +inf by convention).\n"
     << "- **Error**: box 0's exact ground truth is the mesh split at the box faces, subdivided "
        "to edges of half a distance-grid voxel, mapped by the deformer's exact forward map and "
        "rasterised on the CPU. The render is compared with it by the IoU of the silhouettes, "
        "the fraction of pixels covered in both whose depths differ by more than 1 % of the "
        "ground truth's bounding diagonal, and the mean depth error over those pixels. Cuts "
        "remove material, which a mapped mesh cannot show: they have no exact ground truth "
        "here.\n"
     << "- **Frame ms**: the renderer's own time (both passes, first draw to glFinish) over "
     << frames << " frame" << (frames == 1 ? "" : "s")
     << " after one warm-up frame, as median / worst.\n"
     << "- **Verdict**: *pass* when finite, with IoU >= " << fmt("%g", kStabilityMinIoU)
     << " and at most " << fmt("%g", 100 * kStabilityMaxFractionOver)
     << " % of pixels over the depth threshold (or no exact ground truth), and no warning; "
        "*warns* when finite and raywarp warned (its warning explains any error); *fails* on a "
        "NaN or infinity, on an error past the thresholds with no warning, or when rendering "
        "failed; *rejected* when raywarp refused the scene with an error message.\n\n";

  md << "| case | what it stresses | textures finite | image finite | error vs exact ground truth "
        "| frame ms (median / worst) | what raywarp says | verdict |\n"
     << "| --- | --- | --- | --- | --- | --- | --- | --- |\n";
  int pass = 0, warn = 0, fail = 0, rejected = 0;
  // Lexically, not through symbolic links: the link is read where the report sits.
  const std::filesystem::path md_dir =
      std::filesystem::absolute(out_md).lexically_normal().parent_path();
  for (const StabilityCase& c : cases) {
    pass += c.verdict == "pass";
    warn += c.verdict == "warns";
    fail += c.verdict == "fails";
    rejected += c.verdict == "rejected";
    // Link the scene relative to the report, so the link works wherever the repository is.
    std::string name = "`" + c.name + "`";
    if (!c.scene.empty()) {
      const auto rel =
          std::filesystem::absolute(c.scene).lexically_normal().lexically_relative(md_dir);
      if (!rel.empty()) name = "[" + name + "](" + rel.generic_string() + ")";
    }
    std::string says;
    for (const std::string& w : c.warnings) says += (says.empty() ? "" : "; ") + w;
    if (!c.failure.empty()) says += (says.empty() ? "" : "; ") + c.failure;
    const bool rendered = c.failure.empty();
    const bool baked = c.verdict != "rejected";
    md << "| " << name << " | " << cell(c.stresses.empty() ? "—" : c.stresses) << " | "
       << (baked ? yes_no(c.textures_finite) : "—") << " | "
       << (rendered ? yes_no(c.image_finite) : "—") << " | "
       << cell(c.error.empty() ? "—" : c.error) << " | "
       << (rendered ? fmt("%.1f", c.frame_ms) + " / " + fmt("%.1f", c.worst_frame_ms) : "—")
       << " | " << cell(says.empty() ? "—" : says) << " | "
       << (c.verdict == "fails" ? "**fails**" : c.verdict) << " |\n";
  }
  md << "\n"
     << cases.size() << " cases: " << pass << " pass, " << warn << " warn, " << fail << " fail";
  if (rejected > 0) md << ", " << rejected << " rejected";
  md << ".\n";
  const std::string text = md.str();
  write_file_atomic(out_md.string(), text.data(), text.size());
}

}  // namespace raywarp
