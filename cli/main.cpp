// The `raywarp` command line: a thin layer over the library.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "base/error.h"
#include "base/format.h"
#include "base/version.h"
#include "cli/animate.h"
#include "cli/export.h"
#include "cli/library.h"
#include "cli/simulate.h"
#include "deformers/registry.h"
#include "editor/editor.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "gl/tet_scene.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "studies/stability.h"
#include "studies/stiffness.h"
#include "studies/study.h"

namespace fs = std::filesystem;
using namespace raywarp;

namespace {

struct RenderOptions {
  std::string scene, output, depth, mask, camera;
  std::string context = "auto";
  int width = 0, height = 0;
  int time_frames = 0;
  int frames = 0;  // > 0: an animation of this many frames
  std::vector<std::string> params;
  int delay_cs = 4;
  std::string cache_dir;
  bool no_cache = false;
  bool gif_only = false;
  std::string route;      // empty: the scene's render.route
  bool sequence = false;  // every frame of the boxes' from_mesh sequences
};

// The bake cache a command uses: --cache-dir, else the default folder; none with --no-cache or
// when no default folder can be found.
std::unique_ptr<BakeCache> open_cache(const std::string& dir, bool none) {
  if (none) return nullptr;
  fs::path path = dir.empty() ? BakeCache::default_dir() : fs::path(dir);
  if (path.empty()) {
    std::cerr << "note: no bake cache (set RAYWARP_CACHE_DIR, XDG_CACHE_HOME or HOME, or give "
                 "--cache-dir)\n";
    return nullptr;
  }
  return std::make_unique<BakeCache>(path);
}

void report_cache(const BakeCache* cache) {
  if (!cache) return;
  std::cerr << "bake cache " << cache->dir().string() << ": " << cache->hits << " read, "
            << cache->stores << " stored\n";
}

void ensure_parent(const std::string& path) {
  fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) fs::create_directories(parent);
}

// The animated parameters of --param and --sequence, and the frame count (--frames, else the
// longest sequence's).
std::vector<AnimatedParam> animated_params(const std::string& scene_file,
                                           const std::vector<std::string>& params, bool sequence,
                                           int& frames) {
  std::vector<AnimatedParam> out;
  for (const auto& p : params) out.push_back(parse_animated_param(p));
  if (sequence) {
    int longest = 0;
    for (AnimatedParam& p : sequence_params(load_scene(scene_file), &longest))
      out.push_back(std::move(p));
    if (frames == 0) frames = longest;
    if (frames < 2)
      throw Error("--sequence: " + scene_file +
                  ": the sequence has a single frame; leave out --sequence to render it, or "
                  "give --frames N");
  }
  if (!out.empty() && frames == 0)
    throw Error("--param needs --frames N (N >= 2), the sequence's length");
  if (out.empty() && frames > 0)
    throw Error("--frames: give --sequence or a --param FIELD=FROM:TO to animate");
  return out;
}

int run_animation(const RenderOptions& opt) {
  AnimationOptions a;
  a.scene = opt.scene;
  a.frames = opt.frames;
  a.params = animated_params(opt.scene, opt.params, opt.sequence, a.frames);
  a.camera = opt.camera;
  a.width = opt.width;
  a.height = opt.height;
  a.context = opt.context;
  a.output = opt.output;
  a.delay_cs = opt.delay_cs;
  a.write_frames = !opt.gif_only;
  auto cache = open_cache(opt.cache_dir, opt.no_cache);
  a.cache = cache.get();
  if (!opt.depth.empty() || !opt.mask.empty())
    throw Error("--depth and --mask write single frames; leave them out with --frames");
  animate(a, std::cerr);
  report_cache(cache.get());
  return 0;
}

int run_render(const RenderOptions& opt) {
  if (opt.frames > 0 || !opt.params.empty() || opt.sequence) return run_animation(opt);
  Scene scene = load_scene(opt.scene);
  if (!opt.route.empty()) {
    scene.render.route = opt.route;
    if (opt.route == "tets")
      for (size_t i = 0; i < scene.boxes.size(); ++i)
        if (scene.boxes[i].deformer.type != "simulation")
          throw Error("--route tets: " + opt.scene + ": boxes[" + std::to_string(i) +
                      "].deformer.type is \"" + scene.boxes[i].deformer.type +
                      "\"; the tetrahedral route shows simulation boxes only");
  }
  Camera camera;
  if (!opt.camera.empty())
    camera = load_camera(opt.camera);
  else if (scene.camera)
    camera = *scene.camera;
  else
    throw Error(opt.scene + ": camera: missing; give \"camera\" in the scene or --camera FILE");
  Eigen::Vector2i size = image_size(scene, camera, opt.width, opt.height);

  auto cache = open_cache(opt.cache_dir, opt.no_cache);
  const auto bake_start = std::chrono::steady_clock::now();
  PreparedScene prepared = prepare_scene(scene, std::cerr, cache.get());
  std::cerr << "textures: " << prepared.bakes << " baked in "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - bake_start).count()
            << " s (mesh and cache reads included)\n";
  report_cache(cache.get());
  auto context = gl::create_context(opt.context);
  std::cerr << "context: " << context->description() << "\n";
  gl::FrameStats stats;
  std::function<double()> frame;  // renders one more frame, its milliseconds
  Image image;
  std::unique_ptr<gl::Renderer> renderer;
  std::vector<TetBody> bodies;
  std::unique_ptr<gl::TetSceneRenderer> tet_renderer;
  gl::TetSceneStats ts;
  if (scene.render.route == "tets") {
    std::vector<const BoxTextures*> boxes;
    std::vector<const TetBody*> body_list;
    for (size_t i = 0; i < prepared.boxes.size(); ++i) {
      bodies.push_back(build_tet_body(prepared.boxes[i], prepared.mesh(), scene.render.tets));
      const TetBody& b = bodies.back();
      std::cerr << "box " << i << ": tetrahedral route, " << scene.render.tets.mode
                << " mode: " << b.tets.size() << " tetrahedra, " << b.positions.size()
                << " nodes (cells split " << b.refine << "^3) in " << fmt("%.2f", b.seconds)
                << " s\n";
    }
    for (size_t i = 0; i < bodies.size(); ++i) {
      boxes.push_back(&prepared.boxes[i].textures);
      body_list.push_back(&bodies[i]);
    }
    tet_renderer = std::make_unique<gl::TetSceneRenderer>(prepared.mesh(), boxes, body_list,
                                                          scene.render.tets);
    if (scene.render.tets.mode == "volume")
      std::cerr << "pre-integration tables: "
                << fmt("%.1f", tet_renderer->table_bytes() / 1048576.0) << " MiB in "
                << fmt("%.2f", tet_renderer->table_seconds()) << " s\n";
    frame = [&] {
      image = tet_renderer->render(camera, size.x(), size.y(), scene.render, &ts);
      return ts.raster_ms + ts.walk_ms;
    };
    frame();
    std::cerr << "frame: " << size.x() << "x" << size.y() << " in "
              << fmt("%.1f", ts.raster_ms + ts.walk_ms) << " ms (mesh " << fmt("%.1f", ts.raster_ms)
              << ", walk " << fmt("%.1f", ts.walk_ms) << ", " << ts.walk.passes << " peeling passes"
              << (ts.walk.pass_cap_reached ? ", pass cap reached" : "")
              << (ts.walk.capped > 0 ? ", " + std::to_string(ts.walk.capped) + " rays capped" : "")
              << "), " << fmt("%.1f", tet_renderer->mesh_bytes() / 1048576.0)
              << " MiB of tetrahedra\n";
  } else {
    renderer = std::make_unique<gl::Renderer>();
    renderer->set_mesh(prepared.mesh());
    renderer->set_boxes(prepared.textures());
    frame = [&] {
      image = renderer->render(camera, size.x(), size.y(), scene.render, &stats);
      return stats.milliseconds;
    };
    frame();
    std::cerr << "frame: " << size.x() << "x" << size.y() << " in " << stats.milliseconds << " ms, "
              << renderer->texture_bytes() / (1 << 20) << " MiB of textures\n";
  }
  if (opt.time_frames > 0) {
    // The first frame above also paid for llvmpipe's shader compilation; time the rest.
    const Image first = image;
    std::vector<double> ms;
    for (int f = 0; f < opt.time_frames; ++f) ms.push_back(frame());
    image = first;
    std::sort(ms.begin(), ms.end());
    std::cerr << "frames: median " << ms[ms.size() / 2] << " ms of " << opt.time_frames
              << " after the first (min " << ms.front() << ", max " << ms.back() << ")\n";
  }
  if (stats.nonfinite_pixels > 0)
    std::cerr << "warning: " << stats.nonfinite_pixels
              << " pixels had a non-finite depth and were set to background\n";

  ensure_parent(opt.output);
  write_png(opt.output, image);
  std::cerr << "wrote " << opt.output << "\n";
  if (!opt.depth.empty()) {
    ensure_parent(opt.depth);
    write_depth_f32(opt.depth, image);
    nlohmann::json side = {
        {"width", size.x()},
        {"height", size.y()},
        {"format", "float32 little-endian, row-major, row 0 = top"},
        {"depth", "linear eye depth dot(p - eye, normalize(target - eye)); inf = empty"},
        {"camera", camera_to_json(camera)}};
    std::string text = side.dump(2) + "\n";
    write_file_atomic(opt.depth + ".json", text.data(), text.size());
    std::cerr << "wrote " << opt.depth << " and " << opt.depth << ".json\n";
  }
  if (!opt.mask.empty()) {
    ensure_parent(opt.mask);
    write_mask_png(opt.mask, image);
    std::cerr << "wrote " << opt.mask << "\n";
  }
  return 0;
}

struct StudyCli {
  std::vector<std::string> scenes;
  std::string out, context = "auto";
  int size = 256, frames = 5, goal_size = 512;
  bool stability = false, quick = false, stiffness = false;
  bool size_given = false;
};

int run_study_cli(StudyCli opt) {
  if (opt.stiffness) {
    if (opt.stability || opt.scenes.size() > 1)
      throw Error(
          "study --stiffness: takes at most one scene (a simulation scene for the image part) "
          "and not --stability");
    StiffnessOptions so;
    so.out = opt.out;
    if (!opt.scenes.empty()) so.scene = opt.scenes[0];
    so.quick = opt.quick;
    auto context = gl::create_context(opt.context);  // for the image part
    std::cerr << "context: " << context->description() << "\n";
    run_stiffness_study(so, std::cerr);
    return 0;
  }
  if (opt.stability) {
    // The extreme cases; paths as given, so the report names them relative to the repository.
    if (opt.scenes.empty()) {
      const fs::path folder = "examples/extreme";
      if (!fs::is_directory(folder))
        throw Error("study --stability: no scenes given and no " + folder.string() +
                    " folder here; run it from the repository root or name the scenes");
      for (const auto& e : fs::directory_iterator(folder))
        if (e.path().extension() == ".json") opt.scenes.push_back(e.path().generic_string());
      std::sort(opt.scenes.begin(), opt.scenes.end());
    }
    const fs::path out = opt.out.empty() ? fs::path("docs/stability.md") : fs::path(opt.out);
    if (!opt.size_given) opt.size = 128;  // the default of --stability
    auto context = gl::create_context(opt.context);
    std::cerr << "context: " << context->description() << "\n";
    std::vector<fs::path> scenes(opt.scenes.begin(), opt.scenes.end());
    auto cases = run_stability(scenes, opt.size, opt.frames, std::cerr);
    if (!out.parent_path().empty()) fs::create_directories(out.parent_path());
    write_stability_report(cases, out, opt.size, opt.frames, context->description());
    std::cerr << "wrote " << out.string() << "\n";
    for (const auto& c : cases)
      if (c.verdict == "fails") return 1;
    return 0;
  }
  if (opt.scenes.empty()) throw Error("study: give at least one scene file (or --stability)");
  if (opt.out.empty())
    throw Error(
        "study: --out DIR: required (where study.csv, pareto.svg and "
        "report.md go)");
  StudyOptions so;
  for (const auto& s : opt.scenes) so.scenes.emplace_back(s);
  so.out = opt.out;
  so.size = opt.size;
  so.frames = opt.frames;
  so.goal_size = opt.goal_size;
  so.quick = opt.quick;
  auto context = gl::create_context(opt.context);
  so.machine = context->description();
  std::cerr << "context: " << so.machine << "\n";
  run_study(so, std::cerr);
  return 0;
}

struct BakeCli {
  std::string scene, out, formats = "ktx2", cache_dir, engines = "all";
  int box = -1;
  int atlas_border = 0;
  bool float32 = false, dds_legacy = false, orientation = false, no_cache = false;
  int frames = 0;  // > 0: a sequence of this many frames
  std::vector<std::string> params;
  bool sequence = false;
};

int run_bake(const BakeCli& opt) {
  ExportOptions options;
  options.formats = parse_formats(opt.formats, "--format");
  options.storage = opt.float32 ? Storage::Float : Storage::Half;
  options.atlas_border = opt.atlas_border;
  options.dds_legacy = opt.dds_legacy;
  if (opt.orientation) {
    if (!opt.scene.empty())
      throw Error(
          "bake --orientation-test writes the orientation volume only; leave out the "
          "scene file (" +
          opt.scene + ")");
    const nlohmann::json side = export_orientation(options, opt.out);
    for (const auto& f : side["files"])
      std::cerr << "wrote " << (fs::path(opt.out) / f["file"].get<std::string>()).string() << "\n";
    std::cerr << "wrote " << (fs::path(opt.out) / "orientation.json").string() << "\n";
    return 0;
  }
  if (opt.scene.empty()) throw Error("bake: give a scene file (or --orientation-test)");
  auto cache = open_cache(opt.cache_dir, opt.no_cache);
  BakeSession session(cache.get());
  int frames = opt.frames;
  const std::vector<AnimatedParam> params =
      animated_params(opt.scene, opt.params, opt.sequence, frames);
  const std::vector<std::string> engines = parse_engines(opt.engines);
  if (params.empty())
    bake_and_export(opt.scene, options, opt.out, session, std::cerr, opt.box, engines);
  else
    bake_and_export_sequence(opt.scene, params, frames, options, opt.out, session, std::cerr,
                             opt.box, engines);
  report_cache(cache.get());
  return 0;
}

int run_info(const std::string& path) {
  Mesh mesh = load_mesh(path);
  std::cout << describe(mesh_stats(mesh)) << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "raywarp: renders deformations of meshes in image space (Correa & Silver 2007).\n"
      "A deformation box on a mesh gets a signed distance grid of the part inside it and an\n"
      "inverse-displacement texture; the deformed part is ray cast in a fragment shader and\n"
      "composited with the rasterised rest of the mesh.",
      "raywarp"};
  app.set_version_flag("--version", std::string("raywarp ") + kVersion);
  app.require_subcommand(1);

  RenderOptions ropt;
  auto* render =
      app.add_subcommand("render", "Render a scene file to a PNG (and optionally depth and mask)");
  render->add_option("scene", ropt.scene, "Scene file (JSON, see docs/scene.md)")->required();
  render->add_option("-o,--output", ropt.output, "Colour image to write (PNG, 8-bit sRGB)")
      ->required();
  render->add_option(
      "--depth", ropt.depth,
      "Also write linear eye depth: float32 little-endian, H x W, row 0 = top, +inf where "
      "empty; the camera goes beside it in FILE.json");
  render->add_option("--mask", ropt.mask, "Also write the silhouette (PNG, 255 where covered)");
  render->add_option("--camera", ropt.camera, "Camera file overriding the scene's camera");
  render
      ->add_option("--context", ropt.context,
                   "OpenGL context: auto (EGL on a GPU when there is one, else OSMesa), egl "
                   "(headless EGL, on llvmpipe without a GPU), osmesa")
      ->check(CLI::IsMember({"auto", "egl", "osmesa"}))
      ->capture_default_str();
  render->add_option("--width", ropt.width, "Image width in pixels (overrides camera and scene)")
      ->check(CLI::Range(1, 8192));
  render->add_option("--height", ropt.height, "Image height in pixels (overrides camera and scene)")
      ->check(CLI::Range(1, 8192));
  render->add_option("--time", ropt.time_frames, "Also time N more frames and print their median")
      ->check(CLI::Range(1, 10000));
  render
      ->add_option("--frames", ropt.frames,
                   "Render an animation of N frames while each --param runs from FROM to TO: "
                   "OUTPUT_0000.png ... and OUTPUT.gif beside OUTPUT")
      ->check(CLI::Range(2, 10000));
  render->add_option("--param", ropt.params,
                     "FIELD=FROM:TO, a numeric field of the scene file to animate, e.g. "
                     "boxes[0].deformer.angle_deg=0:360 (repeatable). A single twist's angle "
                     "is animated by the texture map M with one bake; other fields re-bake "
                     "every frame");
  render->add_flag("--sequence", ropt.sequence,
                   "Render every frame of the boxes' from_mesh sequences (a folder of deformed "
                   "copies, or a glTF's morph targets; docs/from_mesh.md): one frame per copy, "
                   "or --frames N blending between copies");
  render->add_flag("--gif-only", ropt.gif_only, "With --frames: write the GIF only, no PNG frames");
  render->add_option("--delay", ropt.delay_cs, "GIF frame delay in 1/100 s")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  render->add_option("--cache-dir", ropt.cache_dir,
                     "Bake cache folder (default $RAYWARP_CACHE_DIR, else "
                     "$XDG_CACHE_HOME/raywarp, else ~/.cache/raywarp)");
  render->add_flag("--no-cache", ropt.no_cache, "Bake everything; read and store no cache entry");
  render
      ->add_option("--route", ropt.route,
                   "How boxes are shown, overriding the scene's render.route: texture (the "
                   "deformation texture, ray cast) or tets (a simulation box's tetrahedra walked "
                   "by the tetrahedral ray caster, render.tets; docs/tet_render.md)")
      ->check(CLI::IsMember({"texture", "tets"}));
  render->footer(
      "Image size: --width/--height, else the camera's width/height, else the scene's render "
      "block.\n"
      "Example: raywarp render examples/bunny_twist.json -o out/bunny_twist.png --depth "
      "out/bunny_twist.f32\n"
      "         raywarp render examples/bunny_twist.json -o out/anim/twist.png --frames 60 "
      "--param boxes[0].deformer.angle_deg=0:360");

  BakeCli bopt;
  auto* bake = app.add_subcommand(
      "bake",
      "Bake a scene's boxes and write their textures in the formats game engines and DCC tools "
      "read (KTX2, DDS, OpenVDB, tiled atlases), each box with a JSON sidecar (docs/export.md)");
  bake->add_option("scene", bopt.scene, "Scene file (JSON, see docs/scene.md)");
  bake->add_option("-o,--out", bopt.out, "Output folder (created if missing)")->required();
  bake->add_option("--format", bopt.formats,
                   "Comma-separated: ktx2, dds, vdb, atlas-png, atlas-exr; or all")
      ->capture_default_str();
  bake->add_flag("--float", bopt.float32,
                 "Store 32-bit floats instead of half floats (KTX2, DDS, EXR)");
  bake->add_option("--atlas-border", bopt.atlas_border,
                   "Texels of edge replication around each atlas tile: 0 for engines that slice "
                   "the atlas into a 3D texture, 1 to sample the 2D atlas directly")
      ->check(CLI::Range(0, 1))
      ->capture_default_str();
  bake->add_flag("--dds-legacy", bopt.dds_legacy,
                 "DDS with a D3DFORMAT FourCC (113 for RGBA16F) instead of the DX10 header");
  bake->add_option("--engines", bopt.engines,
                   "Engine bundles to write beside the textures: all (default) or a "
                   "comma-separated list of threejs, unity, unreal, godot; a texture larger than "
                   "an engine's 3D textures (three.js 256 a side, the others 2048) is refused");
  bake->add_option("--box", bopt.box, "Export only this box (0-based)")
      ->check(CLI::NonNegativeNumber);
  bake->add_flag("--orientation-test", bopt.orientation,
                 "Write the orientation test volume (R = u, G = v, B = w, a marked corner) "
                 "instead of a scene's textures");
  bake->add_flag("--sequence", bopt.sequence,
                 "Export every frame of the boxes' from_mesh sequences (as render --sequence): "
                 "SCENE_boxI_fNNNN.* per frame and SCENE_boxI_sequence.json listing them");
  bake->add_option("--frames", bopt.frames,
                   "Export a sequence of N frames while each --param runs from FROM to TO (or "
                   "N frames over --sequence's copies)")
      ->check(CLI::Range(2, 10000));
  bake->add_option("--param", bopt.params,
                   "FIELD=FROM:TO, a numeric field of the scene file to animate (as for render; "
                   "repeatable)");
  bake->add_option("--cache-dir", bopt.cache_dir, "Bake cache folder (as for render)");
  bake->add_flag("--no-cache", bopt.no_cache, "Read and store no bake cache entry");
  bake->footer(
      "Example: raywarp bake examples/bunny_twist.json --out out/export --format ktx2,dds,vdb\n"
      "         raywarp bake examples/bunny_sequence.json --out out/sequence --sequence\n"
      "         raywarp bake --orientation-test --out out/orientation --format all");

  LibraryOptions lopt;
  std::string lib_formats = "ktx2", lib_input, lib_out = "out/library", lib_jobs, lib_cache;
  bool lib_float = false;
  auto* library = app.add_subcommand(
      "library",
      "Build a library of deformation textures from a folder of scene files (or a presets "
      "file): each entry exported with its shaders and a thumbnail, an index, a contact sheet and "
      "a browser viewer (docs/export.md)");
  library->add_option("input", lib_input, "A folder of scene files, or a presets file (JSON)")
      ->required();
  library->add_option("-o,--out", lib_out, "Output folder")->capture_default_str();
  library
      ->add_option("--format", lib_formats,
                   "Comma-separated: ktx2, dds, vdb, atlas-png, atlas-exr; or all (the viewer "
                   "reads ktx2)")
      ->capture_default_str();
  library->add_flag("--float", lib_float, "Store 32-bit floats instead of half floats");
  library
      ->add_option("--atlas-border", lopt.export_options.atlas_border,
                   "Texels of edge replication around each atlas tile (0 or 1)")
      ->check(CLI::Range(0, 1))
      ->capture_default_str();
  library->add_flag("--dds-legacy", lopt.export_options.dds_legacy,
                    "DDS with a D3DFORMAT FourCC instead of the DX10 header");
  library->add_option("--thumbnail-size", lopt.thumbnail_size, "Thumbnail side, pixels")
      ->check(CLI::Range(16, 1024))
      ->capture_default_str();
  library->add_option("--entry", lopt.entry,
                      "Build only this entry (what an emitted job runs); the index is not "
                      "written");
  library->add_option("--emit-jobs", lib_jobs,
                      "Write one command per entry to FILE (for GNU parallel or a Slurm array) "
                      "instead of building");
  library->add_flag("--index-only", lopt.index_only,
                    "Merge the entries present in the output folder into the index, the contact "
                    "sheet and the viewer");
  library->add_flag("--force", lopt.force, "Rebuild entries whose input hash is unchanged");
  library->add_option("--context", lopt.context, "OpenGL context: auto, egl or osmesa")
      ->check(CLI::IsMember({"auto", "egl", "osmesa"}))
      ->capture_default_str();
  library->add_option("--cache-dir", lib_cache, "Bake cache folder (as for render)");
  library->add_flag("--no-cache", lopt.no_cache, "Read and store no bake cache entry");
  library->footer(
      "Example: raywarp library examples/library --out out/library\n"
      "         raywarp library examples/library --out out/library --emit-jobs jobs.txt\n"
      "         parallel < jobs.txt && raywarp library examples/library --out out/library "
      "--index-only");

  std::string cache_dir;
  bool cache_clear = false;
  auto* cache_cmd = app.add_subcommand(
      "cache", "Show the bake cache's folder, entries and size, or empty it with --clear");
  cache_cmd->add_option("--dir", cache_dir, "Cache folder (default as for render)");
  cache_cmd->add_flag("--clear", cache_clear, "Remove every entry");

  std::string info_path;
  auto* info =
      app.add_subcommand("info", "Print a mesh's vertex and face counts, bounds and closedness");
  info->add_option("mesh", info_path, "Mesh file (OBJ, PLY, STL, OFF, glTF, ...)")->required();

  StudyCli sopt;
  auto* study = app.add_subcommand(
      "study",
      "Measure error against frame time of every sampling method over a sweep of settings, "
      "against each scene's exact ground truth; writes DIR/study.csv, DIR/pareto.svg and "
      "DIR/report.md. With --stability: the extreme cases, written to docs/stability.md");
  study->add_option("scenes", sopt.scenes,
                    "Scene files (default with --stability: examples/extreme/*.json; with "
                    "--stiffness: one simulation scene for the image part, default "
                    "examples/bunny_simulation.json)");
  study->add_option("-o,--out", sopt.out,
                    "Output folder (required; with --stability the markdown file, default "
                    "docs/stability.md)");
  study->add_option("--size", sopt.size, "Image side of the sweep (--stability: 128)")
      ->check(CLI::Range(16, 4096))
      ->capture_default_str();
  study->add_option("--frames", sopt.frames, "Timed frames per run, median taken")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  study->add_option("--goal-size", sopt.goal_size, "Image side of the speed goals")
      ->check(CLI::Range(16, 4096))
      ->capture_default_str();
  study->add_flag("--stability", sopt.stability,
                  "Run the extreme and stiff cases instead and write the stability table");
  study->add_flag("--stiffness", sopt.stiffness,
                  "Run the mass-spring stiffness study instead (needs --out DIR; "
                  "docs/physics.md)");
  study->add_flag("--quick", sopt.quick, "Two settings per method and no goals (a smoke test)");
  study->add_option("--context", sopt.context, "OpenGL context: auto, egl or osmesa")
      ->check(CLI::IsMember({"auto", "egl", "osmesa"}))
      ->capture_default_str();
  study->footer(
      "Example: raywarp study examples/bunny_twist.json examples/bunny_cut_solid.json --out "
      "out/study\n"
      "         raywarp study --stability   (from the repository root)\n"
      "         raywarp study --stiffness --out out/stiffness   (from the repository root)");

  SimulateOptions simopt;
  std::string sim_cache_dir;
  bool sim_no_cache = false, sim_gif_only = false;
  auto* simulate_cmd = app.add_subcommand(
      "simulate",
      "Run a scene's simulation boxes once with progress and render every K-th state: "
      "OUTPUT_0000.png ... and OUTPUT.gif");
  simulate_cmd->add_option("scene", simopt.scene, "Scene file with a \"simulation\" deformer")
      ->required();
  simulate_cmd->add_option("-o,--output", simopt.output, "Frames: DIR/NAME.png")->required();
  simulate_cmd
      ->add_option("--every", simopt.every,
                   "Steps between frames (default: the run's steps / 30, at least 1)")
      ->check(CLI::Range(1L, 100000L));
  simulate_cmd->add_option("--camera", simopt.camera, "Camera file overriding the scene's camera");
  simulate_cmd->add_option("--width", simopt.width, "Image width in pixels")
      ->check(CLI::Range(1, 8192));
  simulate_cmd->add_option("--height", simopt.height, "Image height in pixels")
      ->check(CLI::Range(1, 8192));
  simulate_cmd->add_option("--context", simopt.context, "OpenGL context: auto, egl or osmesa")
      ->check(CLI::IsMember({"auto", "egl", "osmesa"}))
      ->capture_default_str();
  simulate_cmd->add_option("--delay", simopt.delay_cs, "GIF frame delay in 1/100 s")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  simulate_cmd->add_flag("--gif-only", sim_gif_only, "Write the GIF only, no PNG frames");
  simulate_cmd->add_option("--cache-dir", sim_cache_dir, "Bake cache folder");
  simulate_cmd->add_flag("--no-cache", sim_no_cache, "Read and store no cache entry");
  simulate_cmd->footer(
      "The run's states are kept in the bake cache: simulating again, or rendering the scene, "
      "reads them.\n"
      "Example: raywarp simulate examples/bunny_simulation.json -o out/simulation/frame.png "
      "--every 10");

  bool deformers_markdown = false;
  auto* deformers_cmd = app.add_subcommand(
      "deformers", "List the deformer types with their parameters, ranges and defaults");
  deformers_cmd->add_flag("--markdown", deformers_markdown,
                          "Print the table of docs/scene.md (Markdown) instead of text");

  editor::EditOptions eopt;
  auto* edit = app.add_subcommand(
      "edit", "Open a window to place boxes, shape deformations and preview cuts, live");
  edit->add_option("input", eopt.input,
                   "A scene file (.json), or a mesh file: then a box with a twist is placed on "
                   "its upper half and the scene is saved beside it as NAME.json")
      ->required();
  edit->add_option("--width", eopt.width, "Window width in pixels")
      ->check(CLI::Range(400, 8192))
      ->capture_default_str();
  edit->add_option("--height", eopt.height, "Window height in pixels")
      ->check(CLI::Range(300, 8192))
      ->capture_default_str();
  edit->add_option("--status-file", eopt.status_file,
                   "Rewrite FILE (JSON: state idle or baking, the state's number, widgets' "
                   "rectangles; docs/editor.md) at every change, for scripts and tests");
  edit->add_option("--frame-log", eopt.frame_log,
                   "Write one line per shown frame to FILE: milliseconds since start, render "
                   "milliseconds (0 when the viewport was not rendered again), 1 while a bake "
                   "runs (else 0)");
  edit->add_option("--up", eopt.up_axis,
                   "A mesh file's up axis, for the box placed on its upper half and the camera")
      ->transform(CLI::CheckedTransformer(std::map<std::string, int>{{"x", 0}, {"y", 1}, {"z", 2}}))
      ->capture_default_str();
  edit->add_option("--shader-dir", eopt.shader_dir,
                   "Read the shaders from DIR (as shaders/ of the source tree) and reload them "
                   "when a file changes, compile errors shown in the window");
  edit->add_option("--cache-dir", eopt.cache_dir, "Bake cache folder (as for render)");
  edit->add_flag("--no-cache", eopt.no_cache, "Read and store no bake cache entry");
  edit->footer(
      "Mouse: left drag orbits, middle drag (or Shift + left) pans, the wheel or a right drag "
      "zooms; F frames the mesh, Shift+F the selected box. Drag a box's handles: a face's dot "
      "moves that face, the centre "
      "moves the box, a ring rotates it.\nKeys: Ctrl+Z undo, Ctrl+Shift+Z redo, Ctrl+S save (the "
      "camera "
      "inline, at the viewport's size), Ctrl+Q quit.\nExample: raywarp edit "
      "examples/bunny_twist.json");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; a bad option or value is bad input: status 2, as for a bad
    // scene field.
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    if (*render) return run_render(ropt);
    if (*edit) return editor::run_editor(eopt);
    if (*info) return run_info(info_path);
    if (*bake) return run_bake(bopt);
    if (*simulate_cmd) {
      auto cache = open_cache(sim_cache_dir, sim_no_cache);
      simopt.cache = cache.get();
      simopt.write_frames = !sim_gif_only;
      simulate(simopt, std::cerr);
      report_cache(cache.get());
      return 0;
    }
    if (*library) {
      lopt.input = lib_input;
      lopt.out = lib_out;
      lopt.emit_jobs = lib_jobs;
      lopt.cache_dir = lib_cache;
      lopt.export_options.formats = parse_formats(lib_formats, "--format");
      lopt.export_options.storage = lib_float ? Storage::Float : Storage::Half;
      return run_library(lopt, std::cerr);
    }
    if (*deformers_cmd) {
      if (deformers_markdown) {
        std::cout << deformer_table();
      } else {
        for (const DeformerType& t : deformer_types()) {
          std::cout << t.name << (t.cuts ? " (cut)" : "") << ": " << t.summary << "\n";
          for (const ParamDecl& p : t.params) {
            std::cout << "  " << p.key << (p.required ? "" : " (default " + p.default_text + ")")
                      << ": " << p.meaning << (p.unit.empty() ? "" : ", " + p.unit) << "\n";
            for (const ParamDecl& q : p.children)
              std::cout << "    " << p.key << "." << q.key
                        << (q.required ? "" : " (default " + q.default_text + ")") << ": "
                        << q.meaning << (q.unit.empty() ? "" : ", " + q.unit) << "\n";
          }
        }
      }
      return 0;
    }
    if (*cache_cmd) {
      const fs::path dir = cache_dir.empty() ? BakeCache::default_dir() : fs::path(cache_dir);
      if (dir.empty())
        throw Error(
            "cache: no folder (set RAYWARP_CACHE_DIR, XDG_CACHE_HOME or HOME, or give --dir)");
      if (cache_clear) {
        std::cout << "removed " << BakeCache::clear(dir) << " entries from " << dir.string()
                  << "\n";
      } else {
        const auto c = BakeCache::contents(dir);
        std::cout << dir.string() << ": " << c.entries << " entries, " << c.bytes / double(1 << 20)
                  << " MiB\n";
      }
      return 0;
    }
    if (*study) {
      sopt.size_given = study->count("--size") > 0;
      return run_study_cli(sopt);
    }
  } catch (const Error& e) {
    std::cerr << "raywarp: error: " << e.what() << "\n";
    return 2;
  } catch (const fs::filesystem_error& e) {
    std::cerr << "raywarp: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "raywarp: internal error: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
