// The `raywarp` command line: a thin layer over the library.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "editor/pipeline.h"
#include "library/error.h"
#include "library/gl/context.h"
#include "library/gl/renderer.h"
#include "library/image.h"
#include "library/scene.h"

namespace fs = std::filesystem;
using namespace raywarp;

namespace {

struct RenderOptions {
  std::string scene, output, depth, mask, camera;
  std::string context = "auto";
  int width = 0, height = 0;
};

void ensure_parent(const std::string& path) {
  fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) fs::create_directories(parent);
}

int run_render(const RenderOptions& opt) {
  Scene scene = load_scene(opt.scene);
  Camera camera;
  if (!opt.camera.empty())
    camera = load_camera(opt.camera);
  else if (scene.camera)
    camera = *scene.camera;
  else
    throw Error(opt.scene + ": camera: missing; give \"camera\" in the scene or --camera FILE");
  Eigen::Vector2i size = image_size(scene, camera, opt.width, opt.height);

  PreparedScene prepared = prepare_scene(scene, std::cerr);
  auto context = gl::create_context(opt.context);
  std::cerr << "context: " << context->description() << "\n";
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh);
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  Image image = renderer.render(camera, size.x(), size.y(), scene.render, &stats);
  std::cerr << "frame: " << size.x() << "x" << size.y() << " in " << stats.milliseconds << " ms, "
            << renderer.texture_bytes() / (1 << 20) << " MiB of textures\n";
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
  app.set_version_flag("--version", "raywarp 0.1.0");
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
  render->footer(
      "Image size: --width/--height, else the camera's width/height, else the scene's render "
      "block.\n"
      "Example: raywarp render examples/bunny_twist.json -o out/bunny_twist.png --depth "
      "out/bunny_twist.f32");

  std::string info_path;
  auto* info =
      app.add_subcommand("info", "Print a mesh's vertex and face counts, bounds and closedness");
  info->add_option("mesh", info_path, "Mesh file (OBJ, PLY, STL, OFF, glTF, ...)")->required();

  CLI11_PARSE(app, argc, argv);
  try {
    if (*render) return run_render(ropt);
    if (*info) return run_info(info_path);
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
