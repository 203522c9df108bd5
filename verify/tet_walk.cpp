#include "verify/tet_walk.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <utility>

#include "base/error.h"
#include "base/parallel.h"
#include "library/triangle_bvh.h"
#include "verify/cpu_shading.h"

namespace raywarp {

namespace {

using cpu_shading::check_image_size;
using cpu_shading::put_colour;
using cpu_shading::shade;
using Vec3 = Eigen::Vector3d;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// How far behind t_in an exit plane may lie and still count (rounding of λ between neighbouring
// tetrahedra), relative to the mesh's and the ray's scale.
constexpr double kBehindTolerance = 1e-9;

// The nearest front boundary face the ray meets with t in [t_lo, t_max] (t > t_lo when strict).
struct Entry {
  int face = -1;  // index into topology().boundary
  double t = 0.0;
};
Entry next_entry(const TetWalkMesh& mesh, const Vec3& o, const Vec3& r, double t_lo, bool strict,
                 double t_max) {
  Entry best;
  double best_t = t_max;
  const TetTopology& topo = mesh.topology();
  const TetGeometry& geo = mesh.geometry();
  mesh.boundary_bvh().for_each_hit(
      o, r, t_lo, [&] { return best_t; },
      [&](int f, const TriangleHit& h) {
        if (h.t < t_lo || (strict && h.t <= t_lo) || h.t > best_t) return;
        if (best.face >= 0 && h.t == best_t) return;  // ties: the first visited
        const int face = mesh.bvh_faces()[f];
        const TetFace& b = topo.boundary[face];
        if (!(r.dot(geo.normal[b.tet][b.face]) < 0.0)) return;  // not a front face
        best = {face, h.t};
        best_t = h.t;
      });
  return best;
}

void add_walk(TetRenderStats& stats, const TetWalkResult& walk) {
  ++stats.rays;
  if (walk.sections > 0) ++stats.entered;
  if (static_cast<int>(stats.sections_histogram.size()) <= walk.sections)
    stats.sections_histogram.resize(walk.sections + 1, 0);
  ++stats.sections_histogram[walk.sections];
  stats.max_sections = std::max(stats.max_sections, walk.sections);
  stats.max_steps = std::max(stats.max_steps, walk.steps);
  stats.total_steps += walk.steps;
  stats.capped += walk.capped ? 1 : 0;
  stats.lost += walk.lost;
}

void merge(TetRenderStats& into, const TetRenderStats& row) {
  into.rays += row.rays;
  into.entered += row.entered;
  into.hits += row.hits;
  if (into.sections_histogram.size() < row.sections_histogram.size())
    into.sections_histogram.resize(row.sections_histogram.size(), 0);
  for (size_t n = 0; n < row.sections_histogram.size(); ++n)
    into.sections_histogram[n] += row.sections_histogram[n];
  into.max_sections = std::max(into.max_sections, row.max_sections);
  into.max_steps = std::max(into.max_steps, row.max_steps);
  into.total_steps += row.total_steps;
  into.capped += row.capped;
  into.lost += row.lost;
}

// Runs per_pixel(x, y, row_stats) over the image by rows, then gathers the rows' statistics.
template <class PerPixel>
void for_each_pixel(int width, int height, TetRenderStats* stats, const PerPixel& per_pixel) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<TetRenderStats> rows(height);
  parallel_for(height, [&](long y) {
    for (int x = 0; x < width; ++x) per_pixel(x, static_cast<int>(y), rows[y]);
  });
  if (!stats) return;
  *stats = TetRenderStats{};
  for (const TetRenderStats& row : rows) merge(*stats, row);
  stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// TetWalkMesh

TetWalkMesh::TetWalkMesh(std::vector<std::array<int, 4>> tets,
                         std::vector<Eigen::Vector3d> positions, std::vector<double> scalar)
    : tets_(std::move(tets)), positions_(std::move(positions)), scalar_(std::move(scalar)) {
  topology_ = tet_topology(tets_, static_cast<int>(positions_.size()));
  build_state();
}

TetWalkMesh::TetWalkMesh(TetTopology topology, std::vector<std::array<int, 4>> tets,
                         std::vector<Eigen::Vector3d> positions, std::vector<double> scalar)
    : topology_(std::move(topology)),
      tets_(std::move(tets)),
      positions_(std::move(positions)),
      scalar_(std::move(scalar)) {
  const size_t count = tets_.size();
  if (topology_.neighbour.size() != count || topology_.neighbour_face.size() != count)
    throw Error("TetWalkMesh: the topology has " + std::to_string(topology_.neighbour.size()) +
                " tetrahedra, the mesh " + std::to_string(count));
  for (size_t t = 0; t < count; ++t)
    for (int k = 0; k < 4; ++k) {
      const int n = topology_.neighbour[t][k];
      const int f = topology_.neighbour_face[t][k];
      if (n < -1 || n >= static_cast<int>(count) || (n >= 0 && (f < 0 || f > 3)))
        throw Error("TetWalkMesh: tetrahedron " + std::to_string(t) + " face " + std::to_string(k) +
                    ": neighbour " + std::to_string(n) + " face " + std::to_string(f) +
                    " is out of range");
    }
  for (const TetFace& b : topology_.boundary)
    if (b.tet < 0 || b.tet >= static_cast<int>(count) || b.face < 0 || b.face > 3)
      throw Error("TetWalkMesh: boundary face (" + std::to_string(b.tet) + ", " +
                  std::to_string(b.face) + ") is out of range");
  build_state();
}

TetWalkMesh::~TetWalkMesh() = default;
TetWalkMesh::TetWalkMesh(TetWalkMesh&&) noexcept = default;
TetWalkMesh& TetWalkMesh::operator=(TetWalkMesh&&) noexcept = default;

void TetWalkMesh::set_state(std::vector<Eigen::Vector3d> positions, std::vector<double> scalar) {
  positions_ = std::move(positions);
  scalar_ = std::move(scalar);
  build_state();
}

void TetWalkMesh::build_state() {
  geometry_ = tet_geometry(topology_, tets_, positions_, scalar_);
  // The boundary faces of degenerate tetrahedra (zero normals, perhaps non-finite positions)
  // are left out of the tree: no ray enters through them.
  std::vector<Triangle3d> faces;
  faces.reserve(topology_.boundary.size());
  bvh_faces_.clear();
  Eigen::AlignedBox3d bounds;
  for (size_t f = 0; f < topology_.boundary.size(); ++f) {
    const TetFace& b = topology_.boundary[f];
    if (geometry_.flag[b.tet] & kTetDegenerate) continue;
    Triangle3d tri;
    for (int c = 0; c < 3; ++c) {
      tri[c] = positions_[tets_[b.tet][kTetFaceVertices[b.face][c]]];
      bounds.extend(tri[c]);
    }
    faces.push_back(tri);
    bvh_faces_.push_back(static_cast<int>(f));
  }
  bvh_ = std::make_unique<TriangleBvh>(std::move(faces));
  diagonal_ = bounds.isEmpty() ? 0.0 : bounds.diagonal().norm();
}

// ---------------------------------------------------------------------------------------------
// The walk

TetWalkResult walk_ray(const TetWalkMesh& mesh, const Eigen::Vector3d& origin,
                       const Eigen::Vector3d& direction, double t_min, double t_max,
                       const std::function<bool(const TetSegment&)>& visit) {
  TetWalkResult result;
  if (mesh.tet_count() == 0 || !(t_min <= t_max)) return result;
  const TetTopology& topo = mesh.topology();
  const TetGeometry& geo = mesh.geometry();
  const Vec3& o = origin;
  const Vec3& r = direction;
  const long cap = mesh.step_cap();

  double t_search = t_min;
  bool strict = false;
  while (true) {
    const Entry entry = next_entry(mesh, o, r, t_search, strict, t_max);
    if (entry.face < 0) break;
    TetSection section;
    section.entry = topo.boundary[entry.face];
    section.t_in = entry.t;
    const int section_index = result.sections++;
    int tet = section.entry.tet, entry_face = section.entry.face;
    double t_in = entry.t;
    bool first = true;
    while (true) {
      if (result.steps >= cap) {
        result.capped = true;
        section.t_out = t_in;
        result.section_list.push_back(section);
        return result;
      }
      ++result.steps;
      if (geo.flag[tet] & kTetDegenerate) {
        ++result.lost;
        break;
      }
      // The exit face: the non-visible face with the smallest λ not behind t_in.
      const double tolerance = kBehindTolerance * (mesh.diagonal() + std::abs(t_in));
      int exit_face = -1;
      double lambda = kInfinity;
      for (int k = 0; k < 4; ++k) {
        if (k == entry_face) continue;
        const Vec3& n = geo.normal[tet][k];
        const double rn = r.dot(n);
        if (!(rn > 0.0)) continue;
        const double l = (geo.offset[tet][k] - n.dot(o)) / rn;
        if (!(l >= t_in - tolerance)) continue;
        if (l < lambda) {
          lambda = l;
          exit_face = k;
        }
      }
      if (exit_face < 0) {
        ++result.lost;
        break;
      }
      TetSegment segment;
      segment.tet = tet;
      segment.section = section_index;
      segment.entry_face = entry_face;
      segment.exit_face = exit_face;
      segment.t_in = t_in;
      segment.t_out = std::max(lambda, t_in);
      segment.first_in_section = first;
      const bool clipped = segment.t_out > t_max;
      if (clipped) {
        segment.t_out = t_max;
        segment.exit_face = -1;
      }
      segment.s_in = geo.scalar_at(tet, o + segment.t_in * r);
      segment.s_out = geo.scalar_at(tet, o + segment.t_out * r);
      first = false;
      t_in = segment.t_out;
      if (!visit(segment)) {
        result.stopped = true;
        section.t_out = t_in;
        result.section_list.push_back(section);
        return result;
      }
      if (clipped) {
        section.t_out = t_in;
        result.section_list.push_back(section);
        return result;
      }
      const int next = topo.neighbour[tet][exit_face];
      if (next < 0) {
        section.exit = {tet, exit_face};
        break;
      }
      entry_face = topo.neighbour_face[tet][exit_face];
      tet = next;
    }
    section.t_out = t_in;
    result.section_list.push_back(section);
    t_search = t_in;
    strict = true;
  }
  return result;
}

std::optional<TetSurfaceHit> surface_hit(const TetWalkMesh& mesh, const Eigen::Vector3d& origin,
                                         const Eigen::Vector3d& direction, double t_min,
                                         double t_max, const SurfaceOptions& options,
                                         TetWalkResult* walk) {
  const TetGeometry& geo = mesh.geometry();
  std::optional<TetSurfaceHit> hit;
  double f_previous = 0.0;
  const TetWalkResult result =
      walk_ray(mesh, origin, direction, t_min, t_max, [&](const TetSegment& s) {
        if (s.first_in_section) {
          if (s.s_in > 0.0 && options.hit_where_entering_inside) {
            TetSurfaceHit h;
            h.t = s.t_in;
            h.point = origin + s.t_in * direction;
            h.normal = geo.normal[s.tet][s.entry_face];
            h.tet = s.tet;
            h.at_entry = true;
            hit = h;
            return false;
          }
          f_previous = s.s_in;
        }
        if (f_previous <= 0.0 && s.s_out > 0.0) {
          // f is g · x + ĝ in this tetrahedron: solve g · (o + t r) + ĝ = 0.
          const Vec3& g = geo.gradient[s.tet];
          const double gr = g.dot(direction);
          double t = s.t_in;
          if (gr > 0.0) t = -(g.dot(origin) + geo.gradient_offset[s.tet]) / gr;
          t = std::clamp(t, s.t_in, s.t_out);
          TetSurfaceHit h;
          h.t = t;
          h.point = origin + t * direction;
          const double gn = g.norm();
          h.normal = gn > 0.0 ? Vec3(-g / gn) : Vec3::Zero();
          h.tet = s.tet;
          hit = h;
          return false;
        }
        f_previous = s.s_out;
        return true;
      });
  if (walk) *walk = result;
  return hit;
}

TetVolumeSample volume_integral(const TetWalkMesh& mesh, const TransferFunction& tf,
                                const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                double t_min, double t_max, const VolumeOptions& options,
                                TetWalkResult* walk) {
  TetVolumeSample out;
  const TetWalkResult result =
      walk_ray(mesh, origin, direction, t_min, t_max, [&](const TetSegment& s) {
        if (!std::isfinite(out.first_entry)) out.first_entry = s.t_in;
        const double length = s.t_out - s.t_in;
        if (!(length > 0.0)) return true;
        const SegmentColour c =
            options.table ? options.table->lookup(s.s_in, s.s_out, length)
                          : preintegrate_exact(tf, s.s_in, s.s_out, length, options.exact_panels);
        out.colour = composite(out.colour, c);
        return out.colour.alpha < options.termination;
      });
  if (walk) *walk = result;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Images

Image render_tet_surface(const TetWalkMesh& mesh, const Camera& camera, int width, int height,
                         const RenderSettings& settings, const SurfaceOptions& options,
                         TetRenderStats* stats) {
  check_image_size("render_tet_surface", width, height);
  Image image(width, height);
  for_each_pixel(width, height, stats, [&](int x, int y, TetRenderStats& row) {
    const Ray ray = camera.pixel_ray(x, y, width, height);
    TetWalkResult walk;
    const auto hit =
        surface_hit(mesh, ray.origin, ray.direction, ray.t_min, ray.t_max, options, &walk);
    add_walk(row, walk);
    if (!hit) {
      put_colour(image, x, y, settings.background);
      return;
    }
    ++row.hits;
    image.depth[static_cast<size_t>(y) * width + x] =
        static_cast<float>(camera.depth_of(hit->point));
    put_colour(image, x, y, shade(settings.colour, hit->normal, ray.direction));
  });
  return image;
}

Image render_tet_volume(const TetWalkMesh& mesh, const TransferFunction& tf, const Camera& camera,
                        int width, int height, const Eigen::Vector3d& background,
                        const VolumeOptions& options, TetRenderStats* stats) {
  check_image_size("render_tet_volume", width, height);
  tf.validate();
  Image image(width, height);
  for_each_pixel(width, height, stats, [&](int x, int y, TetRenderStats& row) {
    const Ray ray = camera.pixel_ray(x, y, width, height);
    TetWalkResult walk;
    const TetVolumeSample v =
        volume_integral(mesh, tf, ray.origin, ray.direction, ray.t_min, ray.t_max, options, &walk);
    add_walk(row, walk);
    put_colour(image, x, y, v.colour.colour + (1.0 - v.colour.alpha) * background);
    if (std::isfinite(v.first_entry))
      image.depth[static_cast<size_t>(y) * width + x] =
          static_cast<float>(camera.depth_of(ray.origin + v.first_entry * ray.direction));
  });
  return image;
}

}  // namespace raywarp
