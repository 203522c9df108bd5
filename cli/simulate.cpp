#include "cli/simulate.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ostream>
#include <sstream>

#include "base/error.h"
#include "base/format.h"
#include "deformers/registry.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/gif.h"
#include "library/prepare.h"
#include "library/scene.h"

namespace raywarp {

namespace fs = std::filesystem;

SimulateResult simulate(const SimulateOptions& opt, std::ostream& log) {
  Scene scene = load_scene(opt.scene);
  std::vector<size_t> boxes;
  long longest = 0;
  for (size_t b = 0; b < scene.boxes.size(); ++b)
    if (needs_mesh(scene.boxes[b].deformer)) {
      boxes.push_back(b);
      longest = std::max(longest, static_cast<long>(scene.boxes[b].deformer.sim_steps));
    }
  if (boxes.empty())
    throw Error(opt.scene.string() +
                ": boxes: no box has a \"simulation\" deformer (raywarp simulate renders the "
                "states of a simulation; use raywarp render --frames for other deformers)");
  if (opt.every < 0) throw Error("--every: must be >= 1 (steps between frames)");
  const long every = opt.every > 0 ? opt.every : std::max(1L, (longest + 29) / 30);
  const int frames = static_cast<int>((longest + every - 1) / every);
  if (frames > 10000)
    throw Error("--every " + std::to_string(every) + ": " + std::to_string(frames) +
                " frames; at most 10000 (raise --every)");

  Camera camera;
  if (!opt.camera.empty())
    camera = load_camera(opt.camera);
  else if (scene.camera)
    camera = *scene.camera;
  else
    throw Error(opt.scene.string() +
                ": camera: missing; give \"camera\" in the scene or --camera FILE");
  const Eigen::Vector2i size = image_size(scene, camera, opt.width, opt.height);
  const fs::path dir = opt.output.parent_path(), stem = opt.output.stem();
  if (stem.empty())
    throw Error("-o " + opt.output.string() + ": give a file name such as out/sim/frame.png");
  if (!dir.empty()) fs::create_directories(dir);

  BakeSession session(opt.cache);
  SimulateResult result;
  const MeshPtr mesh = session.mesh(scene.mesh);
  log << "mesh: " << scene.mesh.string() << " (" << fmt("%.2f", mesh->load_seconds) << " s)\n";
  // One run per simulation box, keeping every `every`-th state.
  for (size_t b : boxes) {
    BakeJob job = make_job(scene, b, mesh);
    job.keep_every = every;
    log << "box " << b << ": simulation of " << static_cast<long>(scene.boxes[b].deformer.sim_steps)
        << " steps, a frame every " << every << " steps\n";
    bake_logged(session, job, log, "box " + std::to_string(b) + ": ");
  }

  auto context = gl::create_context(opt.context);
  log << "context: " << context->description() << "\n";
  gl::Renderer renderer;
  std::vector<Image> images;
  for (int f = 0; f < frames; ++f) {
    const auto start = std::chrono::steady_clock::now();
    const long step = std::min(longest, (f + 1) * every);
    Scene at = scene;
    for (size_t b : boxes) {
      DeformerSpec& d = at.boxes[b].deformer;
      d.sim_steps = static_cast<double>(std::min(static_cast<long>(d.sim_steps), step));
    }
    std::ostringstream quiet;  // each frame's full report would drown the sequence's log
    const long runs = session.counters().simulation;
    const PreparedScene prepared = prepare_scene(at, quiet, session);
    result.simulations += session.counters().simulation - runs;
    renderer.set_mesh(prepared.mesh());
    renderer.set_boxes(prepared.textures());
    const double bake_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    gl::FrameStats stats;
    Image image = renderer.render(camera, size.x(), size.y(), at.render, &stats);
    for (const auto& box : prepared.boxes)
      for (const auto& w : box.report.warning_messages())
        log << "frame " << f + 1 << ": warning: " << w << "\n";
    if (opt.write_frames) {
      char name[32];
      std::snprintf(name, sizeof name, "_%04d.png", f);
      write_png((dir / (stem.string() + name)).string(), image);
    }
    const double dt = scene.boxes[boxes[0]].deformer.dt;
    log << "frame " << f + 1 << "/" << frames << ": step " << step
        << " (t = " << shortest_text(static_cast<double>(step) * dt) << " s), textures in "
        << fmt("%.2f", bake_s) << " s (" << prepared.bakes << " baked), drawn in "
        << fmt("%.1f", stats.milliseconds) << " ms\n"
        << std::flush;
    result.steps.push_back(step);
    result.frame_ms.push_back(stats.milliseconds);
    images.push_back(std::move(image));
  }
  result.frames = frames;
  result.simulations += static_cast<long>(boxes.size());
  result.gif = dir / (stem.string() + ".gif");
  write_gif(result.gif.string(), images, opt.delay_cs);
  log << "simulation runs: " << boxes.size() << " for " << frames << " frames; frame median "
      << fmt("%.1f", median(result.frame_ms)) << " ms\n";
  if (opt.write_frames)
    log << "wrote " << (dir / (stem.string() + "_0000.png")).string() << " ... " << frames
        << " frames, and " << result.gif.string() << "\n";
  else
    log << "wrote " << result.gif.string() << "\n";
  return result;
}

}  // namespace raywarp
