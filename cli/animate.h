// Progressive animation (Correa & Silver 2007, Fig. 4): a scene rendered over N frames while
// parameters of the scene file run from one value to another.
//
// A parameter that the texture map M of eq. 2 can animate is animated with one bake: a twist's
// angle (a single twist in its box, angles of one sign, sampling other than bounded) is baked at
// the largest |angle| of the sequence, and frame k reads it through M = a scale by
// s_k = angle_k / angle_baked along the twist axis about the fixed face -a:
//   q_a -> -h_a + s_k (q_a + h_a),   so theta(M q) = s_k theta(q)  (the twist is linear in t).
// A peel's hinge (a single peel in its box; the paper's progressive peeling) is baked at the
// lowest hinge of the sequence, the longest flap, and frame k reads it, D and the alpha map A,
// through M = a translation by -(hinge_k - hinge_baked) along the peel direction
// (library/texture_map.h).
// Every other parameter re-bakes the scene for each frame, and the log says so.
#pragma once
#include <filesystem>
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "library/bake_cache.h"
#include "library/image.h"
#include "library/scene.h"

namespace raywarp {

// "boxes[0].deformer.angle_deg=0:360": a numeric field of the scene file and its range.
struct AnimatedParam {
  std::string path;  // boxes[0].deformer.angle_deg, render.step_voxels, ...
  double from = 0, to = 0;
  double at(int frame, int frames) const {
    return frames > 1 ? from + (to - from) * frame / (frames - 1) : from;
  }
};
// Parses PATH=FROM:TO; throws Error saying what is expected.
AnimatedParam parse_animated_param(const std::string& text);

// The scene document with each parameter set to its value at `frame` of `frames`. Throws Error
// naming `scene` and the parameter when its path is not a numeric field of the document.
nlohmann::json document_at(const nlohmann::json& document, const std::vector<AnimatedParam>& params,
                           int frame, int frames, const std::filesystem::path& scene);

// `--sequence`: for each box whose from_mesh target is a sequence (a folder of copies, or a glTF
// with morph targets and no `morph` given; library/mesh_pairs.h), its frame from 0 to its last.
// `longest` receives the longest sequence's frame count. Throws Error naming the scene when no
// box has one.
std::vector<AnimatedParam> sequence_params(const Scene& scene, int* longest);

struct AnimationOptions {
  std::filesystem::path scene;
  std::vector<AnimatedParam> params;
  int frames = 60;
  std::string camera;         // camera file overriding the scene's, or empty
  int width = 0, height = 0;  // 0: the camera's or the scene's
  std::string context = "auto";
  // Where frames go: DIR/NAME_0000.png ... and DIR/NAME.gif for output = DIR/NAME.png (or .gif).
  std::filesystem::path output;
  int delay_cs = 4;            // GIF frame delay, hundredths of a second
  bool write_frames = true;    // the numbered PNGs (the GIF is always written)
  BakeCache* cache = nullptr;  // re-bakes read unchanged textures from it (optional)
};

struct AnimationResult {
  int frames = 0;
  int bakes = 0;           // prepare_scene runs: 1 when M animates every parameter
  int textures_baked = 0;  // textures those runs baked (the rest came from the cache)
  bool mapped = false;     // animated by the texture map M
  std::vector<Image> images;
  std::vector<double> frame_ms;
  std::filesystem::path gif;
};

// Renders the sequence, logging per frame what was baked or mapped. Throws Error for a bad
// parameter (naming it and the scene file) before any frame is written.
AnimationResult animate(const AnimationOptions& options, std::ostream& log);

}  // namespace raywarp
