#include "gl/tet_scene.h"

#include "base/error.h"

namespace raywarp::gl {

struct TetSceneRenderer::Impl {
  Renderer raster;
  std::vector<std::unique_ptr<TetRenderer>> walkers;
  std::vector<std::unique_ptr<PreintegrationTable>> tables;  // volume mode, one per box
  TetDisplaySpec spec;
  double table_seconds = 0.0;
};

TetSceneRenderer::TetSceneRenderer(const Mesh& mesh, const std::vector<const BoxTextures*>& boxes,
                                   const std::vector<const TetBody*>& bodies,
                                   const TetDisplaySpec& spec)
    : impl_(std::make_unique<Impl>()) {
  if (boxes.size() != bodies.size())
    throw Error("tetrahedral route: " + std::to_string(bodies.size()) + " bodies for " +
                std::to_string(boxes.size()) + " boxes");
  Impl& m = *impl_;
  m.spec = spec;
  m.raster.set_mesh(mesh);
  m.raster.set_boxes(boxes);
  m.raster.set_ray_cast(false);
  for (const TetBody* body : bodies) {
    auto walker = std::make_unique<TetRenderer>();
    walker->set_mesh(body->tets, static_cast<int>(body->positions.size()));
    const std::vector<double>& scalar = shown_scalar(*body, spec);
    walker->set_state(body->positions, scalar);
    if (spec.mode == "volume") {
      Eigen::AlignedBox3d bounds;
      for (const Eigen::Vector3d& p : body->positions) bounds.extend(p);
      const TransferFunction tf =
          spec.transfer ? *spec.transfer
                        : default_transfer_function(scalar, spec.scalar, bounds.diagonal().norm());
      m.tables.push_back(
          std::make_unique<PreintegrationTable>(tf, tet_table_sizes(*body, spec, tf)));
      m.table_seconds += m.tables.back()->build_seconds();
    }
    m.walkers.push_back(std::move(walker));
  }
}

TetSceneRenderer::~TetSceneRenderer() = default;

Image TetSceneRenderer::render(const Camera& camera, int width, int height,
                               const RenderSettings& settings, TetSceneStats* stats) {
  Impl& m = *impl_;
  FrameStats frame;
  Image image = m.raster.render(camera, width, height, settings, &frame);
  TetSceneStats s;
  s.raster_ms = frame.milliseconds;
  for (size_t b = 0; b < m.walkers.size(); ++b) {
    FrameStats walk_frame;
    const Image part =
        m.spec.mode == "volume"
            ? m.walkers[b]->render_volume(camera, width, height, *m.tables[b], settings.background,
                                          &walk_frame, &s.walk)
            : m.walkers[b]->render_surface(camera, width, height, settings, &walk_frame, &s.walk);
    s.walk_ms += walk_frame.milliseconds;
    image = composite_nearest(image, part);
  }
  if (stats) *stats = s;
  return image;
}

std::size_t TetSceneRenderer::mesh_bytes() const {
  std::size_t n = 0;
  for (const auto& w : impl_->walkers) n += w->mesh_bytes();
  return n;
}

std::size_t TetSceneRenderer::table_bytes() const {
  std::size_t n = 0;
  for (const auto& t : impl_->tables) n += t->bytes();
  return n;
}

double TetSceneRenderer::table_seconds() const { return impl_->table_seconds; }

long TetSceneRenderer::tet_count() const {
  long n = 0;
  for (const auto& w : impl_->walkers) n += w->tet_count();
  return n;
}

}  // namespace raywarp::gl
