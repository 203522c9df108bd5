// The depth-map cube (see depth_cube.h): baked by rasterising the mesh's triangles into the
// texel grid of each axis on the CPU.
#include "library/depth_cube.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <thread>

#include "base/error.h"
#include "library/winding.h"

namespace raywarp {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The other two axes of `axis`, increasing.
void face_axes(int axis, int& u, int& v) {
  u = axis == 0 ? 1 : 0;
  v = axis == 2 ? 1 : 2;
}

// Per texel of an axis's grid: the nearest hit inside the box seen from each of the axis's two
// faces, whether it faces that face (the ray enters the mesh there), and the signed crossings
// before each face (+1 entering, -1 leaving, counted along that face's inward direction).
struct AxisHits {
  std::vector<float> near_lo, near_hi;  // depth from the -axis / +axis face; infinity: none
  std::vector<char> enters_lo, enters_hi;
  std::vector<int> winding_lo, winding_hi;
  explicit AxisHits(size_t texels)
      : near_lo(texels, std::numeric_limits<float>::infinity()),
        near_hi(texels, std::numeric_limits<float>::infinity()),
        enters_lo(texels, 0),
        enters_hi(texels, 0),
        winding_lo(texels, 0),
        winding_hi(texels, 0) {}
};

// 2D edge function of the edge a -> b at p: > 0 left of the edge. Evaluated with the endpoints
// in a fixed (lexicographic) order and negated for the other direction, so that the two triangles
// sharing an edge get exactly opposite values at every point and no ray slips between them.
double edge_function(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  const bool swap = b.x() < a.x() || (b.x() == a.x() && b.y() < a.y());
  const Eigen::Vector2d& s = swap ? b : a;
  const Eigen::Vector2d& e = swap ? a : b;
  const double w = (e.x() - s.x()) * (p.y() - s.y()) - (e.y() - s.y()) * (p.x() - s.x());
  return swap ? -w : w;
}

// Top-left rule for a counter-clockwise triangle (v up): a point on the edge a -> b counts when
// the edge is a left edge (going down) or a top edge (horizontal, going left).
bool owns_edge(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = b - a;
  return d.y() < 0.0 || (d.y() == 0.0 && d.x() < 0.0);
}

// Rasterises every triangle of the mesh (vertices in the box's local frame) into the texel grid
// of `axis` (texel centres origin + (i + 0.5) spacing along the face's u and v).
void rasterise_axis(const std::vector<Eigen::Vector3d>& local, const Mesh& mesh, int axis,
                    const Eigen::Vector3d& h, const DepthMap& grid, AxisHits& hits) {
  const int ua = grid.u_axis, va = grid.v_axis;
  const double s = grid.spacing;
  // The 3D normal's component along `axis` has the sign of the projected signed area (u, v) for
  // axes x and z, and the opposite sign for y ((x, z) is a left-handed pair about y).
  const double handedness = axis == 1 ? -1.0 : 1.0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::Vector3d* q[3] = {&local[mesh.F(f, 0)], &local[mesh.F(f, 1)],
                                   &local[mesh.F(f, 2)]};
    Eigen::Vector2d p[3];
    for (int c = 0; c < 3; ++c) p[c] = Eigen::Vector2d((*q[c])[ua], (*q[c])[va]);
    double area = edge_function(p[0], p[1], p[2]);
    if (area == 0.0 || !std::isfinite(area)) continue;  // edge-on: the rays graze it
    // The normal along +axis (> 0): a ray along +axis (from the -axis face) leaves the mesh.
    const bool normal_up = handedness * area > 0.0;
    if (area < 0.0) {  // counter-clockwise in (u, v)
      std::swap(p[1], p[2]);
      std::swap(q[1], q[2]);
      area = -area;
    }
    const double umin = std::min({p[0].x(), p[1].x(), p[2].x()});
    const double umax = std::max({p[0].x(), p[1].x(), p[2].x()});
    const double vmin = std::min({p[0].y(), p[1].y(), p[2].y()});
    const double vmax = std::max({p[0].y(), p[1].y(), p[2].y()});
    // The texel centres within the triangle's bounds, clamped to the grid in double (a far
    // triangle's index would not fit an int).
    auto first = [&](double lo, double origin, int n) {
      return static_cast<int>(std::clamp(std::ceil((lo - origin) / s - 0.5), 0.0, double(n)));
    };
    auto last = [&](double hi, double origin, int n) {
      return static_cast<int>(std::clamp(std::floor((hi - origin) / s - 0.5), -1.0, n - 1.0));
    };
    const int i0 = first(umin, grid.origin.x(), grid.nu), i1 = last(umax, grid.origin.x(), grid.nu);
    const int j0 = first(vmin, grid.origin.y(), grid.nv), j1 = last(vmax, grid.origin.y(), grid.nv);
    if (i0 > i1 || j0 > j1) continue;
    const bool own[3] = {owns_edge(p[1], p[2]), owns_edge(p[2], p[0]), owns_edge(p[0], p[1])};
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const Eigen::Vector2d c(grid.origin.x() + (i + 0.5) * s, grid.origin.y() + (j + 0.5) * s);
        // w[k]: the edge opposite vertex k, i.e. vertex k's barycentric weight times the area.
        const double w[3] = {edge_function(p[1], p[2], c), edge_function(p[2], p[0], c),
                             edge_function(p[0], p[1], c)};
        bool inside = true;
        for (int k = 0; k < 3; ++k) inside = inside && (w[k] > 0.0 || (w[k] == 0.0 && own[k]));
        if (!inside) continue;
        const double x = (w[0] * (*q[0])[axis] + w[1] * (*q[1])[axis] + w[2] * (*q[2])[axis]) /
                         (w[0] + w[1] + w[2]);
        const size_t t = static_cast<size_t>(j) * grid.nu + i;
        const float depth_lo = static_cast<float>(x + h[axis]),
                    depth_hi = static_cast<float>(h[axis] - x);
        // From the -axis face the ray runs along +axis: it enters where the normal points down.
        if (depth_lo < 0.0f) {
          hits.winding_lo[t] += normal_up ? -1 : 1;
        } else if (depth_hi < 0.0f) {
          hits.winding_hi[t] += normal_up ? 1 : -1;
        } else {
          if (depth_lo < hits.near_lo[t]) {
            hits.near_lo[t] = depth_lo;
            hits.enters_lo[t] = !normal_up;
          }
          if (depth_hi < hits.near_hi[t]) {
            hits.near_hi[t] = depth_hi;
            hits.enters_hi[t] = normal_up;
          }
        }
      }
  }
}

}  // namespace

double DepthMap::sample(double u, double v) const {
  const double x = std::clamp((u - origin.x()) / spacing - 0.5, 0.0, double(nu - 1));
  const double y = std::clamp((v - origin.y()) / spacing - 0.5, 0.0, double(nv - 1));
  const int i0 = std::min(static_cast<int>(x), nu - 1), j0 = std::min(static_cast<int>(y), nv - 1);
  const int i1 = std::min(i0 + 1, nu - 1), j1 = std::min(j0 + 1, nv - 1);
  const double wx = x - i0, wy = y - j0;
  const double lo = at(i0, j0) * (1.0 - wx) + at(i1, j0) * wx;
  const double hi = at(i0, j1) * (1.0 - wx) + at(i1, j1) * wx;
  return lo * (1.0 - wy) + hi * wy;
}

double DepthMap::distance_from_face(const Eigen::Vector3d& p) const {
  return half_extent - side * p[axis];
}

Eigen::Vector2i DepthCube::layer_size() const {
  Eigen::Vector2i size(1, 1);
  for (const DepthMap& m : maps) size = size.cwiseMax(Eigen::Vector2i(m.nu, m.nv));
  return size;
}

std::uint64_t DepthCube::texture_bytes(int bytes_per_texel) const {
  const Eigen::Vector2i size = layer_size();
  return std::uint64_t(size.x()) * std::uint64_t(size.y()) * 6 * bytes_per_texel;
}

long DepthCube::map_texels() const {
  long n = 0;
  for (const DepthMap& m : maps) n += long(m.nu) * m.nv;
  return n;
}

Eigen::Vector3i depth_cube_dims(const Eigen::Vector3d& half_extents, int resolution) {
  const double spacing = 2.0 * half_extents.maxCoeff() / resolution;
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a)
    n[a] = std::max(1, static_cast<int>(std::ceil(2.0 * half_extents[a] / spacing - 1e-9)));
  return n;
}

std::uint64_t depth_cube_bytes(const Eigen::Vector3d& half_extents, int resolution) {
  const Eigen::Vector3i n = depth_cube_dims(half_extents, resolution);
  // Layers of (largest u count) x (largest v count): u is x or y, v is y or z.
  const std::uint64_t w = std::max(n.x(), n.y()), h = std::max(n.y(), n.z());
  return w * h * 6 * sizeof(float);
}

DepthCube bake_depth_cube(const Mesh& mesh, const Box& box, int resolution) {
  if (resolution < 1 || resolution > 65536)
    throw Error("implicit.resolution = " + std::to_string(resolution) +
                ": a depth cube needs a resolution in [1, 65536]");
  const auto start = std::chrono::steady_clock::now();
  DepthCube cube;
  const Eigen::Vector3d& h = box.half_extents;
  cube.half_extents = h;
  cube.spacing = 2.0 * h.maxCoeff() / resolution;
  cube.far_depth = static_cast<float>(kFarDepthBoxes * 2.0 * h.maxCoeff());
  const Eigen::Vector3i n = depth_cube_dims(h, resolution);
  for (int k = 0; k < 6; ++k) {
    DepthMap& m = cube.maps[k];
    m.axis = k / 2;
    m.side = k % 2 ? 1 : -1;
    face_axes(m.axis, m.u_axis, m.v_axis);
    m.half_extent = h[m.axis];
    m.spacing = cube.spacing;
    m.nu = n[m.u_axis];
    m.nv = n[m.v_axis];
    m.origin = -0.5 * cube.spacing * Eigen::Vector2d(m.nu, m.nv);
    m.depth.assign(static_cast<size_t>(m.nu) * m.nv, cube.far_depth);
  }

  std::vector<Eigen::Vector3d> local(static_cast<size_t>(mesh.V.rows()));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    local[i] = box.to_local(mesh.V.row(i).transpose());

  // Where the ray starts inside the mesh the face is no surface of the mesh: -far_depth keeps
  // that face's vote inside all along the ray and its |f_k| out of the min (see depth_cube.h).
  const float inside_depth = -cube.far_depth;
  // Per axis: rasterise, then fill its two maps. Rays with no hit inside the box whose crossings
  // before the two faces disagree (an open mesh) are left for the winding number.
  DepthCubeTexels counts[3];
  std::vector<size_t> undecided[3];
  auto bake_axis = [&](int a) {
    DepthMap& lo = cube.maps[2 * a];
    DepthMap& hi = cube.maps[2 * a + 1];
    AxisHits ah(lo.depth.size());
    rasterise_axis(local, mesh, a, h, lo, ah);
    DepthCubeTexels& c = counts[a];
    for (size_t t = 0; t < lo.depth.size(); ++t) {
      if (std::isfinite(ah.near_lo[t])) {  // then also from the other face
        // The first surface point: where the ray enters the mesh; when it leaves the mesh
        // there, it started inside.
        lo.depth[t] = ah.enters_lo[t] ? ah.near_lo[t] : inside_depth;
        hi.depth[t] = ah.enters_hi[t] ? ah.near_hi[t] : inside_depth;
        c.surface += ah.enters_lo[t] + ah.enters_hi[t];
        c.inside += !ah.enters_lo[t] + !ah.enters_hi[t];
      } else if ((ah.winding_lo[t] > 0) != (ah.winding_hi[t] > 0)) {
        undecided[a].push_back(t);
      } else {  // no surface inside the box: the whole ray is inside or outside
        const bool inside = ah.winding_lo[t] > 0;
        lo.depth[t] = hi.depth[t] = inside ? inside_depth : cube.far_depth;
        (inside ? c.inside : c.empty) += 2;
      }
    }
  };
  // One thread per axis (each writes only its own maps), unless the maps are large: then one
  // axis at a time, so that only one axis's hits (18 bytes a texel) are held at once.
  if (cube.map_texels() / 2 <= (long(1) << 23)) {
    std::vector<std::thread> threads;
    for (int a = 0; a < 3; ++a) threads.emplace_back(bake_axis, a);
    for (auto& t : threads) t.join();
  } else {
    for (int a = 0; a < 3; ++a) bake_axis(a);
  }
  std::unique_ptr<WindingNumber> winding;  // built only if some ray needs it
  for (int a = 0; a < 3; ++a) {
    DepthMap& lo = cube.maps[2 * a];
    DepthMap& hi = cube.maps[2 * a + 1];
    for (size_t t : undecided[a]) {
      if (!winding) winding = std::make_unique<WindingNumber>(mesh);
      const int i = static_cast<int>(t % lo.nu), j = static_cast<int>(t / lo.nu);
      Eigen::Vector3d p = Eigen::Vector3d::Zero();
      p[a] = -h[a];
      p[lo.u_axis] = lo.origin.x() + (i + 0.5) * lo.spacing;
      p[lo.v_axis] = lo.origin.y() + (j + 0.5) * lo.spacing;
      const bool inside = (*winding)(box.to_object(p)) > 0.5;
      lo.depth[t] = hi.depth[t] = inside ? inside_depth : cube.far_depth;
      (inside ? counts[a].inside : counts[a].empty) += 2;
      counts[a].winding_fallbacks += 2;
    }
    cube.texels.surface += counts[a].surface;
    cube.texels.inside += counts[a].inside;
    cube.texels.empty += counts[a].empty;
    cube.texels.winding_fallbacks += counts[a].winding_fallbacks;
  }
  // Each map's silhouette dilated by a texel: an empty texel next to texels that see the surface
  // takes the deepest of their depths (see DepthCube::far_depth).
  for (DepthMap& m : cube.maps) {
    const std::vector<float> original = m.depth;
    for (int j = 0; j < m.nv; ++j)
      for (int i = 0; i < m.nu; ++i) {
        float& h = m.depth[static_cast<size_t>(j) * m.nu + i];
        if (h != cube.far_depth) continue;
        float deepest = -1.0f;
        for (int y = std::max(j - 1, 0); y <= std::min(j + 1, m.nv - 1); ++y)
          for (int x = std::max(i - 1, 0); x <= std::min(i + 1, m.nu - 1); ++x) {
            const float n = original[static_cast<size_t>(y) * m.nu + x];
            if (n >= 0.0f && n != cube.far_depth) deepest = std::max(deepest, n);
          }
        if (deepest < 0.0f) continue;
        h = deepest;
        ++cube.texels.dilated;
      }
  }
  cube.bake_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return cube;
}

double depth_cube_value(const DepthCube& cube, const Eigen::Vector3d& p) {
  bool inside = true;
  double nearest = kInfinity;
  for (const DepthMap& m : cube.maps) {
    const double f = m.distance_from_face(p) - m.sample(p[m.u_axis], p[m.v_axis]);
    inside = inside && f > 0.0;
    nearest = std::min(nearest, std::abs(f));
  }
  return inside ? nearest : -nearest;
}

std::string describe(const DepthCube& cube) {
  const Eigen::Vector2i layer = cube.layer_size();
  const std::string fallbacks =
      cube.texels.winding_fallbacks
          ? ", " + std::to_string(cube.texels.winding_fallbacks) + " by winding number (open mesh)"
          : std::string();
  char buf[320];
  std::snprintf(
      buf, sizeof buf,
      "depth cube: 6 maps (x %dx%d, y %dx%d, z %dx%d) in a %dx%dx6 array, texel %.4g, "
      "%.2f MiB; texels: %ld surface, %ld inside, %ld empty (%ld of them dilated)%s (%.2f s)",
      cube.maps[0].nu, cube.maps[0].nv, cube.maps[2].nu, cube.maps[2].nv, cube.maps[4].nu,
      cube.maps[4].nv, layer.x(), layer.y(), cube.spacing, cube.texture_bytes() / double(1 << 20),
      cube.texels.surface, cube.texels.inside, cube.texels.empty, cube.texels.dilated,
      fallbacks.c_str(), cube.bake_seconds);
  return buf;
}

}  // namespace raywarp
