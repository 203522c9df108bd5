#include "cli/animate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <ostream>
#include <regex>
#include <sstream>

#include "base/clock.h"
#include "base/error.h"
#include "base/format.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/gif.h"
#include "library/mesh_pairs.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "library/texture_map.h"

namespace raywarp {

namespace fs = std::filesystem;
using json = nlohmann::json;

AnimatedParam parse_animated_param(const std::string& text) {
  const std::string expected =
      "--param " + text +
      ": expected FIELD=FROM:TO with a numeric field of the scene file, e.g. "
      "boxes[0].deformer.angle_deg=0:360";
  const size_t eq = text.find('='), colon = text.find(':', eq == std::string::npos ? 0 : eq);
  if (eq == std::string::npos || eq == 0 || colon == std::string::npos) throw Error(expected);
  AnimatedParam p;
  p.path = text.substr(0, eq);
  try {
    size_t used_from = 0, used_to = 0;
    const std::string from = text.substr(eq + 1, colon - eq - 1), to = text.substr(colon + 1);
    p.from = std::stod(from, &used_from);
    p.to = std::stod(to, &used_to);
    if (used_from != from.size() || used_to != to.size()) throw Error(expected);
  } catch (const std::logic_error&) {
    throw Error(expected);
  }
  if (!std::isfinite(p.from) || !std::isfinite(p.to)) throw Error(expected + " (finite numbers)");
  return p;
}

namespace {

// Sets the numeric field at `path` (a.b[2].c) of the scene document to `value`. Every step but
// the last must exist; the last may be a new key of an existing object.
void set_field(json& doc, const AnimatedParam& param, double value, const fs::path& scene) {
  const std::string where = scene.string() + ": --param " + param.path;
  static const std::regex step(R"(([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\])");
  json* node = &doc;
  std::string walked;
  auto it = std::sregex_iterator(param.path.begin(), param.path.end(), step);
  size_t consumed = 0;
  std::vector<std::smatch> steps;
  for (; it != std::sregex_iterator(); ++it) steps.push_back(*it);
  for (size_t i = 0; i < steps.size(); ++i) {
    const std::smatch& m = steps[i];
    // Steps are separated by '.' before a name (except the first) and nothing before [i].
    size_t expected_pos = consumed + (m[1].matched && i > 0 ? 1 : 0);
    if (static_cast<size_t>(m.position()) != expected_pos ||
        (m[1].matched && i > 0 && param.path[consumed] != '.'))
      throw Error(where + ": not a field path such as boxes[0].deformer.angle_deg");
    consumed = m.position() + m.length();
    const bool last = i + 1 == steps.size();
    if (m[1].matched) {
      const std::string key = m[1].str();
      if (!node->is_object())
        throw Error(where + ": " + (walked.empty() ? "the scene" : walked) + " is not an object");
      walked += (walked.empty() ? "" : ".") + key;
      if (!node->contains(key) && !last) throw Error(where + ": the scene has no " + walked);
      node = &(*node)[key];
    } else {
      const size_t index = std::stoul(m[2].str());
      if (!node->is_array() || index >= node->size())
        throw Error(where + ": " + walked + " has no element " + std::to_string(index));
      walked += "[" + std::to_string(index) + "]";
      node = &(*node)[index];
    }
  }
  if (steps.empty() || consumed != param.path.size())
    throw Error(where + ": not a field path such as boxes[0].deformer.angle_deg");
  if (!node->is_null() && !node->is_number())
    throw Error(where + ": " + walked + " is " + node->dump() + ", not a number");
  *node = value;
}

}  // namespace

json document_at(const json& document, const std::vector<AnimatedParam>& params, int frame,
                 int frames, const fs::path& scene) {
  json doc = document;
  for (const auto& p : params) set_field(doc, p, p.at(frame, frames), scene);
  return doc;
}

std::vector<AnimatedParam> sequence_params(const Scene& scene, int* longest) {
  std::vector<AnimatedParam> out;
  int most = 0;
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    const DeformerSpec& d = scene.boxes[i].deformer;
    if (d.type != "from_mesh" || d.morph >= 0) continue;
    const int frames = sequence_frames(d.target);
    if (frames <= 0) continue;
    AnimatedParam p;
    p.path = "boxes[" + std::to_string(i) + "].deformer.frame";
    p.from = 0;
    p.to = frames - 1;
    out.push_back(p);
    most = std::max(most, frames);
  }
  if (out.empty())
    throw Error("--sequence: " + scene.file.string() +
                ": no box's from_mesh target is a sequence (a folder of deformed copies, or a "
                "glTF with morph targets and no \"morph\" given)");
  if (longest) *longest = most;
  return out;
}

namespace {

// What M animates: a twist's angle (a scale along its axis) or a peel's hinge (a translation
// along the peel direction; library/texture_map.h).
enum class Mapped { none, twist_angle, peel_hinge };

// The box whose twist angle or peel hinge alone is animated, when M can animate it, and how;
// -1 otherwise, with the reason in `why`.
int mapped_box(const Scene& scene, const std::vector<AnimatedParam>& params, Mapped& how,
               std::string& why) {
  how = Mapped::none;
  if (params.size() != 1) {
    why = "more than one parameter";
    return -1;
  }
  static const std::regex field(R"(boxes\[(\d+)\]\.deformer(\[0\])?\.(angle_deg|hinge))");
  std::smatch m;
  const AnimatedParam& p = params[0];
  if (!std::regex_match(p.path, m, field)) {
    why = p.path + " is neither a twist's angle nor a peel's hinge";
    return -1;
  }
  const size_t box = std::stoul(m[1].str());
  const bool angle = m[3].str() == "angle_deg";
  const char* type = angle ? "twist" : "peel";
  if (box >= scene.boxes.size() || scene.boxes[box].deformer.type != type ||
      !scene.boxes[box].then.empty()) {
    why = p.path + " is not the " + (angle ? "angle" : "hinge") + " of a box's only deformer, a " +
          type;
    return -1;
  }
  if (scene.render.sampling == Sampling::Bounded) {
    why = "the bounded tracer's step bounds hold for the texture as baked";
    return -1;
  }
  if (scene.boxes[box].mapping.cylindrical) {
    why = "the box's textures are cylindrical, read at p' and not through M";
    return -1;
  }
  if (angle) {
    if (p.from * p.to < 0.0) {
      why = "the angle changes sign (a twist is scaled about its fixed face, not mirrored)";
      return -1;
    }
    if (p.from == 0.0 && p.to == 0.0) {
      why = "the angle stays 0";
      return -1;
    }
  }
  how = angle ? Mapped::twist_angle : Mapped::peel_hinge;
  return static_cast<int>(box);
}

}  // namespace

AnimationResult animate(const AnimationOptions& opt, std::ostream& log) {
  if (opt.frames < 2 || opt.frames > 10000)
    throw Error("--frames " + std::to_string(opt.frames) + ": must be 2 to 10000");
  if (opt.params.empty())
    throw Error("--frames: give at least one --param FIELD=FROM:TO to animate");
  const json document = read_scene_document(opt.scene);
  auto scene_at = [&](int frame) {
    return load_scene_json(document_at(document, opt.params, frame, opt.frames, opt.scene),
                           opt.scene);
  };
  // Every frame's scene is validated before anything is baked or written.
  std::vector<Scene> scenes;
  for (int f = 0; f < opt.frames; ++f) scenes.push_back(scene_at(f));
  const Scene& first = scenes.front();

  Camera camera;
  if (!opt.camera.empty())
    camera = load_camera(opt.camera);
  else if (first.camera)
    camera = *first.camera;
  else
    throw Error(opt.scene.string() +
                ": camera: missing; give \"camera\" in the scene or --camera FILE");
  const Eigen::Vector2i size = image_size(first, camera, opt.width, opt.height);

  fs::path dir = opt.output.parent_path(), stem = opt.output.stem();
  if (stem.empty())
    throw Error("-o " + opt.output.string() + ": give a file name such as out/anim.png");
  if (!dir.empty()) fs::create_directories(dir);

  AnimationResult result;
  result.frames = opt.frames;
  std::string why;
  Mapped how = Mapped::none;
  const int mapped = mapped_box(first, opt.params, how, why);
  result.mapped = mapped >= 0;

  auto context = gl::create_context(opt.context);
  log << "context: " << context->description() << "\n";
  gl::Renderer renderer;
  PreparedScene prepared;
  double baked_value = 0.0;  // the twist's angle or the peel's hinge of the one bake
  // One session for the sequence: the mesh is loaded once, and what a frame does not change
  // (the distance grid) is read from memory.
  BakeSession session(opt.cache);
  if (result.mapped) {
    // Bake once: at the frame with the largest |angle| (M scales it down), or with the lowest
    // hinge, the longest flap (M translates it, shortening the flap).
    const AnimatedParam& p = opt.params[0];
    const int widest = how == Mapped::twist_angle
                           ? (std::abs(p.to) >= std::abs(p.from) ? opt.frames - 1 : 0)
                           : (p.to <= p.from ? opt.frames - 1 : 0);
    baked_value = widest ? p.to : p.from;
    log << "animation: " << p.path << " from " << shortest_text(p.from) << " to "
        << shortest_text(p.to) << " over " << opt.frames
        << " frames by the texture map M of eq. 2 ("
        << (how == Mapped::twist_angle ? "a scale along the twist's axis"
                                       : "a translation along the peel direction")
        << "): one bake, at " << shortest_text(baked_value)
        << (how == Mapped::twist_angle ? " degrees\n" : "\n");
    prepared = prepare_scene(scenes[widest], log, session, true);
    ++result.bakes;
    result.textures_baked += prepared.bakes;
    renderer.set_mesh(prepared.mesh());
    renderer.set_boxes(prepared.textures());
  } else {
    log << "animation: " << opt.params.size() << " parameter(s) over " << opt.frames
        << " frames, re-baked every frame (" << why << ")\n";
  }

  for (int f = 0; f < opt.frames; ++f) {
    const auto start = std::chrono::steady_clock::now();
    std::string what;
    if (result.mapped) {
      const BoxSpec& spec = scenes[f].boxes[mapped];
      const BoxTextures& baked = prepared.boxes[mapped].textures;
      if (how == Mapped::twist_angle) {
        const double s = spec.deformer.angle_deg / baked_value;  // in [0, 1]
        const TextureMapping m = twist_angle_mapping(spec, baked, baked_value);
        renderer.set_texture_map(mapped, m.map, m.region, m.lipschitz);
        what = "mapped (s = " + fmt("%.4g", s) + ", no bake)";
      } else {
        const TextureMapping m = peel_hinge_mapping(spec, baked, baked_value);
        renderer.set_texture_map(mapped, m.map, m.region, m.lipschitz);
        what =
            "mapped (shifted by " + fmt("%.4g", spec.deformer.hinge - baked_value) + ", no bake)";
      }
    } else {
      std::ostringstream bake_log;
      prepared = prepare_scene(scenes[f], bake_log, session);
      ++result.bakes;
      result.textures_baked += prepared.bakes;
      renderer.set_mesh(prepared.mesh());
      renderer.set_boxes(prepared.textures());
      for (const auto& b : prepared.boxes)
        for (const auto& w : b.report.warning_messages())
          log << "frame " << f << ": warning: " << w << "\n";
      what = "re-baked (" + std::to_string(prepared.bakes) +
             " textures baked, the rest from memory or the "
             "cache) in " +
             fmt("%.2f", seconds_since(start)) + " s";
    }
    gl::FrameStats stats;
    Image image = renderer.render(camera, size.x(), size.y(), scenes[f].render, &stats);
    if (stats.nonfinite_pixels > 0)
      log << "frame " << f << ": warning: " << stats.nonfinite_pixels
          << " pixels had a non-finite depth and were set to background\n";
    result.frame_ms.push_back(stats.milliseconds);
    if (opt.write_frames) {
      char name[32];
      std::snprintf(name, sizeof name, "_%04d.png", f);
      write_png((dir / (stem.string() + name)).string(), image);
    }
    std::string values;
    for (const auto& p : opt.params)
      values += p.path + " = " + shortest_text(p.at(f, opt.frames)) + " ";
    log << "frame " << f + 1 << "/" << opt.frames << ": " << values << what << ", drawn in "
        << fmt("%.1f", stats.milliseconds) << " ms\n"
        << std::flush;
    result.images.push_back(std::move(image));
  }
  result.gif = dir / (stem.string() + ".gif");
  write_gif(result.gif.string(), result.images, opt.delay_cs);
  log << "bakes: " << result.bakes << " for " << opt.frames << " frames (" << result.textures_baked
      << " textures baked); frame median " << fmt("%.1f", median(result.frame_ms)) << " ms\n";
  if (opt.write_frames)
    log << "wrote " << (dir / (stem.string() + "_0000.png")).string() << " ... " << opt.frames
        << " frames, and " << result.gif.string() << "\n";
  else
    log << "wrote " << result.gif.string() << "\n";
  return result;
}

}  // namespace raywarp
