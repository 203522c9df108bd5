#include "editor/handles.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace raywarp::editor {

std::optional<Eigen::Vector2d> ViewMapping::project(const Eigen::Vector3d& p) const {
  const Eigen::Vector4d eye = camera.view() * p.homogeneous();
  if (camera.projection == Camera::Projection::Perspective && -eye.z() < camera.near_plane)
    return std::nullopt;
  const Eigen::Vector4d clip = camera.projection_matrix(width / height) * eye;
  if (!(std::abs(clip.w()) > 0.0)) return std::nullopt;
  const double nx = clip.x() / clip.w(), ny = clip.y() / clip.w();
  if (!std::isfinite(nx) || !std::isfinite(ny)) return std::nullopt;
  return Eigen::Vector2d(x + 0.5 * (nx + 1.0) * width, y + 0.5 * (1.0 - ny) * height);
}

Ray ViewMapping::ray(const Eigen::Vector2d& pixel) const {
  return camera.ray_at(pixel.x() - x, pixel.y() - y, int(std::lround(width)),
                       int(std::lround(height)));
}

double ViewMapping::units_per_pixel(const Eigen::Vector3d& p) const {
  if (camera.projection == Camera::Projection::Orthographic) return camera.ortho_height / height;
  const double depth = std::max(camera.depth_of(p), camera.near_plane);
  return 2.0 * depth * std::tan(0.5 * camera.fov_y_deg * M_PI / 180.0) / height;
}

std::string Handle::name() const {
  const char* axes = "xyz";
  switch (kind) {
    case Kind::Face:
      return std::string("face") + (side > 0 ? "+" : "-") + axes[axis];
    case Kind::Ring:
      return std::string("ring.") + axes[axis];
    case Kind::Centre:
      break;
  }
  return "centre";
}

double ring_radius(const Box& box, int axis) {
  const Eigen::Vector3d& h = box.half_extents;
  return 1.15 * std::max(h[(axis + 1) % 3], h[(axis + 2) % 3]);
}

namespace {

// The world point on the ring of `axis` at angle t (radians) about it.
Eigen::Vector3d ring_point(const Box& box, int axis, double t) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  q[u] = std::cos(t);
  q[v] = std::sin(t);
  return box.to_object(ring_radius(box, axis) * q);
}

Eigen::Vector3d face_centre(const Box& box, int axis, int side) {
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  q[axis] = side * box.half_extents[axis];
  return box.to_object(q);
}

// The parameter t of the point of the line P + t u nearest the ray (Q, v); 0 when they are
// parallel.
double line_parameter(const Eigen::Vector3d& P, const Eigen::Vector3d& u, const Ray& ray) {
  const Eigen::Vector3d w = P - ray.origin;
  const double a = u.dot(u), b = u.dot(ray.direction), c = ray.direction.dot(ray.direction);
  const double d = u.dot(w), e = ray.direction.dot(w);
  const double denom = a * c - b * b;
  if (!(denom > 1e-12 * a * c)) return 0.0;
  return (b * e - c * d) / denom;
}

// Where the ray meets the plane through `point` with normal `n`; none when it runs along it.
std::optional<Eigen::Vector3d> plane_hit(const Ray& ray, const Eigen::Vector3d& point,
                                         const Eigen::Vector3d& n) {
  const double dn = ray.direction.dot(n);
  if (std::abs(dn) < 1e-9) return std::nullopt;
  const double t = (point - ray.origin).dot(n) / dn;
  return ray.origin + t * ray.direction;
}

double segment_distance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                        const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

}  // namespace

std::vector<Eigen::Vector2d> ring_polyline(const Box& box, int axis, const ViewMapping& view,
                                           int segments) {
  std::vector<Eigen::Vector2d> out;
  for (int i = 0; i < segments; ++i) {
    const auto p = view.project(ring_point(box, axis, 2.0 * M_PI * i / segments));
    if (!p) return {};
    out.push_back(*p);
  }
  return out;
}

std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> box_edges(const Box& box) {
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> edges;
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    for (int su : {-1, 1})
      for (int sv : {-1, 1}) {
        Eigen::Vector3d lo = Eigen::Vector3d::Zero();
        lo[u] = su * box.half_extents[u];
        lo[v] = sv * box.half_extents[v];
        Eigen::Vector3d hi = lo;
        lo[a] = -box.half_extents[a];
        hi[a] = box.half_extents[a];
        edges.emplace_back(box.to_object(lo), box.to_object(hi));
      }
  }
  return edges;
}

std::vector<PlacedHandle> place_handles(const Box& box, const ViewMapping& view) {
  std::vector<PlacedHandle> out;
  if (const auto c = view.project(box.centre)) out.push_back({Handle{Handle::Kind::Centre}, *c});
  for (int a = 0; a < 3; ++a)
    for (int side : {1, -1})
      if (const auto p = view.project(face_centre(box, a, side)))
        out.push_back({Handle{Handle::Kind::Face, a, side}, *p});
  // A ring is grabbed by the point of it farthest from the centre on screen, where it is least
  // likely to lie under a dot.
  const auto centre = view.project(box.centre);
  for (int a = 0; a < 3; ++a) {
    const std::vector<Eigen::Vector2d> ring = ring_polyline(box, a, view);
    if (ring.empty() || !centre) continue;
    const Eigen::Vector2d far = *std::max_element(
        ring.begin(), ring.end(), [&](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
          return (p - *centre).squaredNorm() < (q - *centre).squaredNorm();
        });
    out.push_back({Handle{Handle::Kind::Ring, a}, far});
  }
  return out;
}

std::optional<Handle> pick_handle(const Box& box, const ViewMapping& view,
                                  const Eigen::Vector2d& mouse, double radius_px) {
  std::optional<Handle> best;
  double best_distance = radius_px;
  for (const PlacedHandle& h : place_handles(box, view)) {
    if (h.handle.kind == Handle::Kind::Ring) continue;
    const double d = (h.pixel - mouse).norm();
    if (d <= best_distance) {
      best = h.handle;
      best_distance = d;
    }
  }
  if (best) return best;
  for (int a = 0; a < 3; ++a) {
    const std::vector<Eigen::Vector2d> ring = ring_polyline(box, a, view);
    for (size_t i = 0; i < ring.size(); ++i) {
      const double d = segment_distance(mouse, ring[i], ring[(i + 1) % ring.size()]);
      if (d <= best_distance) {
        best = Handle{Handle::Kind::Ring, a};
        best_distance = d;
      }
    }
  }
  return best;
}

Box drag_handle(const Box& start, const Handle& handle, const ViewMapping& view,
                const Eigen::Vector2d& from, const Eigen::Vector2d& to, double min_half) {
  Box box = start;
  const Ray r0 = view.ray(from), r1 = view.ray(to);
  switch (handle.kind) {
    case Handle::Kind::Face: {
      const Eigen::Vector3d n = start.rotation.col(handle.axis) * double(handle.side);
      const Eigen::Vector3d f = face_centre(start, handle.axis, handle.side);
      const double moved = line_parameter(f, n, r1) - line_parameter(f, n, r0);
      const double h = start.half_extents[handle.axis];
      const double h_new = std::max(min_half, h + 0.5 * moved);
      if (!std::isfinite(h_new)) return start;
      box.half_extents[handle.axis] = h_new;
      box.centre = start.centre + n * (h_new - h);
      return box;
    }
    case Handle::Kind::Centre:
      box.centre = drag_point(start.centre, view, from, to);
      return box;
    case Handle::Kind::Ring: {
      const auto c = view.project(start.centre);
      if (!c) return start;
      const Eigen::Vector2d p = from - *c, q = to - *c;
      if (p.norm() < 1.0 || q.norm() < 1.0) return start;
      // Screen angles with y up; a turn counter-clockwise on screen is a positive turn about an
      // axis that points at the viewer.
      double turn = std::atan2(-q.y(), q.x()) - std::atan2(-p.y(), p.x());
      const Eigen::Vector3d axis = start.rotation.col(handle.axis);
      const Eigen::Vector3d to_viewer = view.camera.projection == Camera::Projection::Perspective
                                            ? Eigen::Vector3d(view.camera.eye - start.centre)
                                            : Eigen::Vector3d(-view.camera.view_direction());
      if (axis.dot(to_viewer) < 0.0) turn = -turn;
      box.rotation = (Eigen::AngleAxisd(turn, axis) * start.rotation).eval();
      // Orthonormal to rounding, as the scene reader keeps it.
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(box.rotation,
                                                  Eigen::ComputeFullU | Eigen::ComputeFullV);
      box.rotation = svd.matrixU() * svd.matrixV().transpose();
      return box;
    }
  }
  return box;
}

Eigen::Vector3d drag_point(const Eigen::Vector3d& start, const ViewMapping& view,
                           const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
  const Eigen::Vector3d n = view.camera.view_direction();
  const auto a = plane_hit(view.ray(from), start, n), b = plane_hit(view.ray(to), start, n);
  if (!a || !b || !(*b - *a).allFinite()) return start;
  return start + (*b - *a);
}

std::optional<Eigen::Vector3d> surface_point(const ViewMapping& view,
                                             const std::vector<float>& depth, int width, int height,
                                             const Eigen::Vector2d& pixel) {
  const int ix = int(std::floor(pixel.x() - view.x)), iy = int(std::floor(pixel.y() - view.y));
  if (ix < 0 || iy < 0 || ix >= width || iy >= height ||
      depth.size() != size_t(width) * size_t(height))
    return std::nullopt;
  const double d = depth[size_t(iy) * width + ix];
  if (!std::isfinite(d)) return std::nullopt;
  const Ray r = view.camera.pixel_ray(ix, iy, width, height);
  const double along = r.direction.dot(view.camera.view_direction());  // depth per unit of t
  if (!(along > 0.0)) return std::nullopt;
  return Eigen::Vector3d(r.origin + r.direction * ((d - view.camera.depth_of(r.origin)) / along));
}

Eigen::Vector3d euler_deg_of(const Eigen::Matrix3d& rotation) {
  const Eigen::Vector3d zyx = rotation.eulerAngles(2, 1, 0);  // R = Rz(z) Ry(y) Rx(x)
  Eigen::Vector3d deg(zyx[2], zyx[1], zyx[0]);
  deg *= 180.0 / M_PI;
  for (int k = 0; k < 3; ++k)
    if (deg[k] > 180.0) deg[k] -= 360.0;
  return deg;
}

}  // namespace raywarp::editor
